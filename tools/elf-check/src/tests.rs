//! The analysis on small synthetic programs (text in the format of `llvm-nm -S -n -C`,
//! `llvm-objdump -d --no-show-raw-insn` and `llvm-objdump -s`), where every expected
//! number is counted by hand from the listing.
use super::*;
use crate::firmware::Allowed;

const NM: &str = "\
00000100 00000020 T root
00000200 00000010 t leaf
00000300 00000010 t tail
00000400 00000008 t core::panicking::panic_bounds_check
00000500 00000010 t via_pointer
00000600 00000010 t pointee::h0123456789abcdef
00000700 00000010 t rec_a
00000800 00000010 t rec_b
00000900 00000010 t alloca
20001000 A _stack_start
20000100 B __sheap
";

/// root: frame 4 regs + 16 = 32 B; calls leaf, tail-calls tail (b.w).
/// leaf: 2 regs + 2 d-regs = 24 B. tail: 8 B, calls the panic (a bounds check).
/// via_pointer: 8 B, `blx r3`; pointee (address taken in .rodata): 16 B.
/// rec_a <-> rec_b: 8 B each. alloca: `sub sp, r0`.
const DIS: &str = "
00000100 <root>:
     100:      \tpush\t{r4, r5, r7, lr}
     102:      \tsub\tsp, #16
     104:      \tcmp\tr0, #3
     106:      \tbls\t0x10c <root+0xc>
     108:      \tbl\t0x200 <leaf> @ imm = #244
     10c:      \tadd\tsp, #16
     10e:      \tpop.w\t{r4, r5, r7, lr}
     112:      \tb.w\t0x300 <tail>      @ imm = #490

00000200 <leaf>:
     200:      \tpush\t{r7, lr}
     202:      \tvpush\t{d8, d9}
     206:      \tvpop\t{d8, d9}
     20a:      \tpop\t{r7, pc}

00000300 <tail>:
     300:      \tpush\t{r7, lr}
     302:      \tcmp\tr0, r1
     304:      \tbhs\t0x30a <tail+0xa>
     306:      \tpop\t{r7, pc}
     308:      \tnop
     30a:      \tbl\t0x400 <core::panicking::panic_bounds_check>

00000400 <core::panicking::panic_bounds_check>:
     400:      \tb\t0x400 <core::panicking::panic_bounds_check>

00000500 <via_pointer>:
     500:      \tpush\t{r7, lr}
     502:      \tldr\tr3, [r0, #4]
     504:      \tblx\tr3
     506:      \tpop\t{r7, pc}

00000600 <pointee::h0123456789abcdef>:
     600:      \tpush\t{r4, r5, r6, lr}
     602:      \tbl\t0x400 <core::panicking::panic_bounds_check>

00000700 <rec_a>:
     700:      \tpush\t{r7, lr}
     702:      \tbl\t0x800 <rec_b>
     706:      \tpop\t{r7, pc}

00000800 <rec_b>:
     800:      \tpush\t{r7, lr}
     802:      \tbl\t0x700 <rec_a>
     806:      \tbl\t0x200 <leaf>
     80a:      \tpop\t{r7, pc}

00000900 <alloca>:
     900:      \tpush\t{r7, lr}
     902:      \tsub.w\tsp, sp, r0
     906:      \tpop\t{r7, pc}
";

/// Vector table: SP, Reset = root, NMI = leaf. `.rodata` holds pointee's address | 1.
const DATA: &str = "
Contents of section .vector_table:
 0000 00100020 01010000 01020000           ...
Contents of section .rodata:
 0a00 00000000 01060000 ffffffff           ........
";

fn program() -> Program {
    Program::parse(NM, DIS, DATA).unwrap()
}

fn idx(p: &Program, name: &str) -> usize {
    p.find_exact(name)[0]
}

#[test]
fn parses_functions_vectors_and_address_taken() {
    let p = program();
    assert_eq!(p.funcs.len(), 9);
    assert_eq!(p.orphan_insns, 0);
    assert_eq!(p.initial_sp, 0x2000_1000);
    assert_eq!(p.vectors, vec![(1, 0x100), (2, 0x200)]);
    // Only pointee's address is stored as data (the vector table is kept apart).
    let taken: Vec<&str> = p.address_taken.iter().map(|a| p.funcs[p.func_at(*a).unwrap()].base_name()).collect();
    assert_eq!(taken, ["pointee"]);
    assert_eq!(p.symbols.get("_stack_start"), Some(&0x2000_1000));
}

#[test]
fn control_flow_classification() {
    let i = |m: &str, o: &str| Insn { addr: 0, mnemonic: m.into(), operands: o.into() };
    assert_eq!(flow(&i("bl", "0x200 <leaf>")), Flow::Call(0x200));
    assert_eq!(flow(&i("bls", "0x10c <root+0xc>")), Flow::Branch(0x10c)); // b + ls, not bl + s
    assert_eq!(flow(&i("blo.w", "0x10c <root+0xc>")), Flow::Branch(0x10c));
    assert_eq!(flow(&i("b.w", "0x300 <tail>")), Flow::Branch(0x300));
    assert_eq!(flow(&i("cbz", "r0, 0x30a <tail+0xa>")), Flow::Branch(0x30a));
    assert_eq!(flow(&i("blx", "r3")), Flow::Indirect);
    assert_eq!(flow(&i("blxne", "r1")), Flow::Indirect);
    assert_eq!(flow(&i("bx", "r3")), Flow::Indirect);
    assert_eq!(flow(&i("bx", "lr")), Flow::None);
    assert_eq!(flow(&i("pop", "{r4, pc}")), Flow::None);
    assert_eq!(flow(&i("ldr.w", "pc, [sp], #4")), Flow::None);
    assert_eq!(flow(&i("ldr", "pc, [r0, #8]")), Flow::Indirect);
    assert_eq!(flow(&i("mov", "pc, r2")), Flow::Indirect);
    assert_eq!(flow(&i("tbb", "[pc, r1]")), Flow::None);
}

#[test]
fn stack_effects_of_prologues() {
    let i = |m: &str, o: &str| Insn { addr: 0x10, mnemonic: m.into(), operands: o.into() };
    assert_eq!(stack_alloc(&i("push", "{r4, r5, r6, r7, lr}")), Ok(20));
    assert_eq!(stack_alloc(&i("push.w", "{r8, r9, r10, r11}")), Ok(16));
    assert_eq!(stack_alloc(&i("vpush", "{d8, d9, d10, d11, d12, d13, d14, d15}")), Ok(64));
    assert_eq!(stack_alloc(&i("vpush", "{s16, s17}")), Ok(8));
    assert_eq!(stack_alloc(&i("sub", "sp, #12")), Ok(12));
    assert_eq!(stack_alloc(&i("sub.w", "sp, sp, #7392")), Ok(7392));
    assert_eq!(stack_alloc(&i("subw", "sp, sp, #1000")), Ok(1000));
    assert_eq!(stack_alloc(&i("str", "r4, [sp, #-8]!")), Ok(8));
    assert_eq!(stack_alloc(&i("stmdb", "sp!, {r4, r5}")), Ok(8));
    assert_eq!(stack_alloc(&i("add", "sp, #16")), Ok(0));
    assert_eq!(stack_alloc(&i("sub", "r0, sp, #16")), Ok(0));
    assert!(stack_alloc(&i("sub.w", "sp, sp, r0")).is_err());
    assert!(stack_alloc(&i("mov", "sp, r4")).is_err());
}

#[test]
fn a_panic_behind_a_tail_call_is_found_with_its_path() {
    let p = program();
    let g = Graph::build(&p, &[], &BTreeSet::new());
    let root = idx(&p, "root");
    let found = reachable_panics(&p, &g, &[root]);
    assert_eq!(found.len(), 1);
    assert_eq!(found[0], "root\n    -> tail\n    -> core::panicking::panic_bounds_check");
    // leaf alone reaches no panic; the conditional `bls` inside root is not a call.
    assert!(reachable_panics(&p, &g, &[idx(&p, "leaf")]).is_empty());
    assert!(!g.edges[root].contains(&root));
    // Cutting the one call site (proved impossible) removes it.
    let g = Graph::build(&p, &[], &BTreeSet::from([0x30a]));
    assert!(reachable_panics(&p, &g, &[root]).is_empty());
}

#[test]
fn indirect_calls_need_a_rule_and_rules_add_edges_to_address_taken_functions() {
    let p = program();
    let vp = idx(&p, "via_pointer");
    let g = Graph::build(&p, &[], &BTreeSet::new());
    let unresolved = unresolved_indirect(&p, &g, &[vp]);
    assert_eq!(unresolved.len(), 1);
    assert!(unresolved[0].starts_with("via_pointer (indirect at 0x504)"), "{unresolved:?}");
    // No edge without a rule: the panic behind the pointer is invisible...
    assert!(reachable_panics(&p, &g, &[vp]).is_empty());
    // ...and found once the rule resolves the pointer to the address-taken `pointee`.
    let rules = [IndirectRule { caller: "via_pointer", targets: &["pointee"], why: "test" }];
    let g = Graph::build(&p, &rules, &BTreeSet::new());
    assert!(unresolved_indirect(&p, &g, &[vp]).is_empty());
    let found = reachable_panics(&p, &g, &[vp]);
    assert_eq!(found, ["via_pointer\n    -> pointee\n    -> core::panicking::panic_bounds_check"]);
    // A rule naming a function whose address is never taken resolves to nothing.
    let rules = [IndirectRule { caller: "via_pointer", targets: &["leaf"], why: "test" }];
    assert_eq!(Graph::build(&p, &rules, &BTreeSet::new()).empty_rules, [0]);
}

#[test]
fn stack_is_the_longest_chain_recursion_and_dynamic_frames_are_errors() {
    let p = program();
    let g = Graph::build(&p, &[], &BTreeSet::new());
    let stop: BTreeSet<usize> = (0..p.funcs.len()).filter(|&f| is_panic(&p.funcs[f])).collect();
    let s = Stack::compute(&p, &g, &stop, &[]);
    assert_eq!(s.frame[idx(&p, "root")], Ok(32));
    assert_eq!(s.frame[idx(&p, "leaf")], Ok(24));
    // root 32 + max(leaf 24, tail 8 + panic 0) = 56.
    assert_eq!(s.depth[idx(&p, "root")], Ok(56));
    assert_eq!(s.chain(&p, idx(&p, "root")).lines().count(), 2);
    let e = s.depth[idx(&p, "rec_a")].clone().unwrap_err();
    assert!(e.contains("recursion through"), "{e}");
    let e = s.depth[idx(&p, "alloca")].clone().unwrap_err();
    assert!(e.contains("dynamic stack allocation"), "{e}");
}

#[test]
fn bounded_recursion_costs_depth_times_the_cycle() {
    let p = program();
    let g = Graph::build(&p, &[], &BTreeSet::new());
    let bounds = [RecursionBound { anchor: "rec_a", max_depth: 5, why: "test" }];
    let s = Stack::compute(&p, &g, &BTreeSet::new(), &bounds);
    // 5 levels × (rec_a 8 + rec_b 8) + leaf 24 (the call leaving the cycle) = 104.
    assert_eq!(s.depth[idx(&p, "rec_a")], Ok(104));
    assert_eq!(s.depth[idx(&p, "rec_b")], Ok(104));
    assert_eq!(s.recursions.len(), 1);
}

/// The firmware-level check on the synthetic program: a panic site is accepted only when
/// its source location is the one a proof was written for.
#[test]
fn panic_sites_are_accepted_only_at_the_proved_location() {
    static PROVED: &[Allowed] =
        &[Allowed { callee: "core::panicking::panic_bounds_check", at: &["lib.rs:7"], proof: "test" }];
    static WITH_PROOF: &[&[Allowed]] = &[PROVED];
    let board = |allowed: &'static [&'static [Allowed]]| Board {
        name: "synthetic",
        panic_roots: &["root"],
        terminal_handlers: &["leaf"],
        rules: &[],
        tasks: 0,
        allowed,
        recursion: &[],
    };
    let at = |line: &'static str| {
        move |addrs: &[u32]| -> Vec<String> { addrs.iter().map(|_| format!("f at /src/{line}\n")).collect() }
    };
    let a = Analysis::new(&board(WITH_PROOF), program(), &at("lib.rs:7"));
    assert!(a.errors.is_empty(), "{:?}", a.errors);
    // Thread: Reset = root, 56 B; no handler left (NMI = leaf is terminal).
    assert_eq!(a.bound, 56);
    let a = Analysis::new(&board(WITH_PROOF), program(), &at("lib.rs:70"));
    assert!(
        a.errors.iter().any(|e| e.starts_with("panic reachable: tail -> core::panicking::panic_bounds_check")),
        "{:?}",
        a.errors
    );
    let a = Analysis::new(&board(&[]), program(), &at("lib.rs:7"));
    assert!(!a.errors.is_empty());
}

#[test]
fn rust_escapes_and_hashes() {
    assert_eq!(
        unescape_rust("_$LT$core..fmt..Formatter$u20$as$u20$Foo$GT$::pad::h0123456789abcdef"),
        "<core::fmt::Formatter as Foo>::pad::h0123456789abcdef"
    );
    assert_eq!(strip_hash("a::b::h0123456789abcdef"), "a::b");
    assert_eq!(strip_hash("a::b::hello"), "a::b::hello");
}
