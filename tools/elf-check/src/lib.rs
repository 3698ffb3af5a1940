//! Static checks of the firmware ELF (Thumb-2, Cortex-M4F), from its disassembly.
//!
//! Input: the text of `llvm-objdump -d --no-show-raw-insn` (code and the literal pools
//! between it), `llvm-nm -S -n --defined-only -C` (function ranges, demangled names) and
//! `llvm-objdump -s` of the data sections (function pointers in vtables and in the vector
//! table). Parsing text keeps the tool free of ELF/disassembler dependencies; the LLVM
//! binutils are the ones rustc itself uses (Debian package `llvm`).
//!
//! Analyses (see docs/elf-check.md):
//! - call graph: `bl`, `b`/`b<cond>`/`cbz`/`cbnz` whose target lies outside the current
//!   function (tail calls), and indirect calls (`blx rN`, `bx rN` other than `bx lr`,
//!   `mov pc`, `ldr pc` not from the stack). Indirect edges come only from explicit
//!   [`IndirectRule`]s: an indirect call in a reachable function without a rule is an error;
//!   a rule's targets are the *address-taken* functions (address | 1 stored in data, in a
//!   literal pool or built by `movw`/`movt`) that match its patterns.
//! - panic reachability: no function of the panic family is reachable from the roots.
//! - stack: per-function frame = sum of every stack-pointer decrement in the function
//!   (`push`, `vpush`, `stmdb sp!`, `str rX, [sp, #-N]!`, `sub sp, #N`), an upper bound
//!   (shrink-wrapped prologues on several paths are all counted); a decrement by a register
//!   (dynamic allocation) makes the bound unknown; then the longest path in the call graph,
//!   where recursion is an error.
#![forbid(unsafe_code)]

use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::fmt::Write as _;

/// One function of the ELF: a `t`/`T`/`w`/`W` symbol with a non-zero size.
#[derive(Debug, Clone)]
pub struct Func {
    /// Demangled name, with the legacy hash (`::h0123…`) kept to tell instances apart.
    pub name: String,
    pub start: u32,
    pub end: u32,
    /// Other symbols at the same address (e.g. `BusFault` = `DefaultHandler`).
    pub aliases: Vec<String>,
}

impl Func {
    /// The name without the trailing `::h<16 hex>` hash.
    pub fn base_name(&self) -> &str {
        strip_hash(&self.name)
    }

    fn matches(&self, pattern: &str) -> bool {
        self.base_name().contains(pattern) || self.aliases.iter().any(|a| strip_hash(a).contains(pattern))
    }
}

pub fn strip_hash(name: &str) -> &str {
    match name.rfind("::h") {
        Some(i) if name.len() == i + 19 && name[i + 3..].bytes().all(|b| b.is_ascii_hexdigit()) => &name[..i],
        _ => name,
    }
}

/// Decode the `$LT$`-style escapes that LLVM's (Itanium) demangler leaves in Rust legacy
/// symbol names (rustc-demangle's table, `rustc_demangle::legacy`).
pub fn unescape_rust(name: &str) -> String {
    const ESC: [(&str, &str); 13] = [
        ("$SP$", "@"),
        ("$BP$", "*"),
        ("$RF$", "&"),
        ("$LT$", "<"),
        ("$GT$", ">"),
        ("$LP$", "("),
        ("$RP$", ")"),
        ("$C$", ","),
        ("$u20$", " "),
        ("$u27$", "'"),
        ("$u5b$", "["),
        ("$u5d$", "]"),
        ("$u7e$", "~"),
    ];
    let mut s = name.to_string();
    for (from, to) in ESC {
        s = s.replace(from, to);
    }
    s = s.replace("$u7b$", "{").replace("$u7d$", "}").replace("$u3b$", ";").replace("..", "::");
    // A path segment that starts with an escape is prefixed with `_` by the mangler.
    s = s.replace("::_<", "::<").replace("::_&", "::&");
    if let Some(rest) = s.strip_prefix("_<") {
        s = format!("<{rest}");
    }
    s
}

/// One decoded instruction (`mnemonic` lower-case, condition/width suffixes kept).
#[derive(Debug, Clone)]
pub struct Insn {
    pub addr: u32,
    pub mnemonic: String,
    pub operands: String,
}

/// The parsed program.
#[derive(Debug, Default)]
pub struct Program {
    pub funcs: Vec<Func>,
    /// Instructions of each function (same index as `funcs`).
    pub code: Vec<Vec<Insn>>,
    /// Instructions outside every function symbol (reported, never silently dropped).
    pub orphan_insns: usize,
    /// Function addresses stored as data or built in registers (value with the Thumb bit).
    pub address_taken: BTreeSet<u32>,
    /// Handlers from the vector table: (exception number, handler address).
    pub vectors: Vec<(u32, u32)>,
    /// Initial stack pointer (vector table word 0).
    pub initial_sp: u32,
    /// Other symbols (name → address): `_stack_start`, `__ebss`, `__sheap`, …
    pub symbols: HashMap<String, u32>,
}

fn parse_hex(s: &str) -> Option<u32> {
    u32::from_str_radix(s.trim().trim_start_matches("0x"), 16).ok()
}

impl Program {
    /// Build from the texts of `llvm-nm -S -n --defined-only -C`, `llvm-objdump -d
    /// --no-show-raw-insn` and `llvm-objdump -s` of the data sections (`.vector_table`
    /// first word is the initial SP when present).
    pub fn parse(nm: &str, disasm: &str, data_dump: &str) -> Result<Program, String> {
        let mut p = Program::default();
        // Functions: sized text symbols; zero-sized ones at the same address are aliases.
        let mut zero_sized: Vec<(u32, String)> = Vec::new();
        for line in nm.lines() {
            let mut it = line.splitn(4, ' ');
            let (Some(a), Some(b), Some(c)) = (it.next(), it.next(), it.next()) else { continue };
            // `addr size type name` or `addr type name` (no size).
            let (addr, size, ty, name) = match it.next() {
                Some(name) => (parse_hex(a), parse_hex(b), c, name.to_string()),
                None => (parse_hex(a), Some(0), b, c.to_string()),
            };
            let (Some(addr), Some(size)) = (addr, size) else { continue };
            let name = unescape_rust(&name);
            if matches!(ty, "t" | "T" | "w" | "W") {
                let start = addr & !1;
                if size == 0 {
                    zero_sized.push((start, name));
                } else {
                    p.funcs.push(Func { name, start, end: start.saturating_add(size), aliases: Vec::new() });
                }
            } else {
                p.symbols.insert(name, addr);
            }
        }
        p.funcs.sort_by_key(|f| f.start);
        p.funcs.dedup_by(|b, a| {
            // Identical code folded under two names: keep one, remember the other.
            if a.start == b.start && a.end == b.end {
                a.aliases.push(b.name.clone());
                true
            } else {
                false
            }
        });
        for (addr, name) in zero_sized {
            p.symbols.insert(name.clone(), addr);
            if let Some(i) = p.func_at(addr)
                && p.funcs[i].start == addr
            {
                p.funcs[i].aliases.push(name);
            }
        }
        p.code = vec![Vec::new(); p.funcs.len()];

        let mut words: Vec<u32> = Vec::new();
        for line in disasm.lines() {
            let Some((a, rest)) = line.split_once(':') else { continue };
            let a = a.trim();
            if a.is_empty() || !a.bytes().all(|b| b.is_ascii_hexdigit()) || line.ends_with(">:") {
                continue;
            }
            let Some(addr) = parse_hex(a) else { continue };
            let parts: Vec<&str> = rest.split('\t').map(str::trim).filter(|s| !s.is_empty()).collect();
            if let Some(k) = parts.iter().position(|s| *s == ".word") {
                if let Some(v) = parts.get(k + 1).and_then(|v| parse_hex(v)) {
                    words.push(v);
                }
                continue;
            }
            let Some(mnemonic) = parts.first() else { continue };
            if mnemonic.starts_with('.') {
                continue; // .short / .byte padding in literal pools
            }
            let operands = parts.get(1).map_or("", |o| o.split('@').next().unwrap_or("").trim());
            let insn = Insn { addr, mnemonic: mnemonic.to_ascii_lowercase(), operands: operands.to_string() };
            match p.func_at(addr) {
                Some(i) => p.code[i].push(insn),
                None => p.orphan_insns += 1,
            }
        }
        // Data sections: `llvm-objdump -s` rows ` addr w0 w1 w2 w3  ascii`, bytes in memory order.
        let mut section = String::new();
        let mut section_start: Option<u32> = None;
        for line in data_dump.lines() {
            if let Some(rest) = line.strip_prefix("Contents of section ") {
                section = rest.trim_end_matches(':').to_string();
                section_start = None;
                continue;
            }
            if !line.starts_with(' ') {
                continue;
            }
            let mut fields = line.split_whitespace();
            let Some(base) = fields.next().and_then(parse_hex) else { continue };
            let start = *section_start.get_or_insert(base);
            let mut bytes: Vec<u8> = Vec::new();
            for f in fields.take(4) {
                if f.len() % 2 != 0 || !f.bytes().all(|b| b.is_ascii_hexdigit()) {
                    break;
                }
                for k in (0..f.len()).step_by(2) {
                    bytes.extend(u8::from_str_radix(&f[k..k + 2], 16).ok());
                }
            }
            for (k, w) in bytes.chunks_exact(4).enumerate() {
                let v = u32::from_le_bytes([w[0], w[1], w[2], w[3]]);
                if section == ".vector_table" {
                    let index = (base - start) / 4 + k as u32;
                    if index == 0 {
                        p.initial_sp = v;
                    } else if v != 0 {
                        p.vectors.push((index, v & !1));
                    }
                } else {
                    words.push(v);
                }
            }
        }
        // Function pointers built in registers: movw/movt pairs (and lone movw: the QEMU
        // image's code starts at 0, so a 16-bit immediate can be a code address).
        for insns in &p.code {
            let mut lo: HashMap<String, u32> = HashMap::new();
            for i in insns {
                let m = i.mnemonic.trim_end_matches(".w");
                let (reg, imm) = match i.operands.split_once(", #") {
                    Some((r, v)) => (r.to_string(), v.trim().parse::<u32>().ok()),
                    None => continue,
                };
                let Some(imm) = imm else { continue };
                if m.starts_with("movw") {
                    lo.insert(reg, imm);
                    words.push(imm);
                } else if m.starts_with("movt")
                    && let Some(l) = lo.get(&reg)
                {
                    words.push((imm << 16) | (l & 0xffff));
                }
            }
        }
        let thumb_entries: BTreeSet<u32> = p.funcs.iter().map(|f| f.start | 1).collect();
        p.address_taken = words.into_iter().filter(|v| thumb_entries.contains(v)).collect();
        Ok(p)
    }

    /// Index of the function containing `addr`.
    pub fn func_at(&self, addr: u32) -> Option<usize> {
        let i = self.funcs.partition_point(|f| f.start <= addr);
        let i = i.checked_sub(1)?;
        (addr < self.funcs[i].end).then_some(i)
    }

    pub fn find(&self, pattern: &str) -> Vec<usize> {
        (0..self.funcs.len()).filter(|&i| self.funcs[i].matches(pattern)).collect()
    }

    /// Exact match on the name without hash (or an alias).
    pub fn find_exact(&self, name: &str) -> Vec<usize> {
        (0..self.funcs.len())
            .filter(|&i| {
                let f = &self.funcs[i];
                f.base_name() == name || f.aliases.iter().any(|a| strip_hash(a) == name)
            })
            .collect()
    }
}

const CONDS: [&str; 17] =
    ["eq", "ne", "cs", "hs", "cc", "lo", "mi", "pl", "vs", "vc", "hi", "ls", "ge", "lt", "gt", "le", "al"];

fn is_cond(s: &str) -> bool {
    s.is_empty() || CONDS.contains(&s)
}

/// What an instruction does to control flow.
#[derive(Debug, PartialEq, Eq)]
pub enum Flow {
    None,
    /// `bl` (call) or a branch (`b`, `b<cond>`, `cbz`, `cbnz`) to an address.
    Call(u32),
    Branch(u32),
    /// Register-indirect call or jump.
    Indirect,
}

pub fn flow(i: &Insn) -> Flow {
    let m = i.mnemonic.trim_end_matches(".w").trim_end_matches(".n");
    let target = || {
        i.operands.split([' ', ',']).find_map(|t| t.strip_prefix("0x").and_then(|h| u32::from_str_radix(h, 16).ok()))
    };
    let ops = i.operands.as_str();
    if let Some(c) = m.strip_prefix("blx").or_else(|| m.strip_prefix("bx"))
        && is_cond(c)
    {
        return if ops == "lr" && m.starts_with("bx") { Flow::None } else { Flow::Indirect };
    }
    if m == "cbz" || m == "cbnz" {
        return target().map_or(Flow::None, Flow::Branch);
    }
    if let Some(c) = m.strip_prefix("bl")
        && (c.is_empty() || (c.len() == 2 && CONDS.contains(&c) && c != "lo" && c != "ls" && c != "le" && c != "lt"))
    {
        return target().map_or(Flow::Indirect, Flow::Call);
    }
    if let Some(c) = m.strip_prefix('b')
        && is_cond(c)
    {
        return target().map_or(Flow::Indirect, Flow::Branch);
    }
    // Writes to pc other than returns.
    let first = ops.split(',').next().unwrap_or("").trim();
    if (m.starts_with("mov") || m.starts_with("add")) && first == "pc" {
        return Flow::Indirect;
    }
    if m.starts_with("ldr") && first == "pc" && !ops.contains("[sp") {
        return Flow::Indirect;
    }
    if (m.starts_with("ldm") || m.starts_with("pop"))
        && ops.contains("pc")
        && !(m.starts_with("pop") || ops.starts_with("sp"))
    {
        return Flow::Indirect;
    }
    Flow::None
}

/// Register count of a `{r4, r5, lr}` / `{d8, d9}` list: (count, bytes per register).
fn reg_list(ops: &str) -> (u32, u32) {
    let inner = ops.split_once('{').and_then(|(_, r)| r.split_once('}')).map_or("", |(l, _)| l);
    let mut n = 0u32;
    let mut width = 4;
    for r in inner.split(',').map(str::trim).filter(|r| !r.is_empty()) {
        if r.starts_with('d') {
            width = 8;
        }
        // Ranges `d8-d15` are counted too (llvm-objdump lists registers, but be safe).
        n += match r.split_once('-') {
            Some((a, b)) => {
                let (a, b) = (a[1..].parse::<u32>().unwrap_or(0), b.trim()[1..].parse::<u32>().unwrap_or(0));
                b.saturating_sub(a) + 1
            }
            None => 1,
        };
    }
    (n, width)
}

/// Stack effect of one instruction: bytes allocated, or `Err` for a dynamic allocation.
pub fn stack_alloc(i: &Insn) -> Result<u32, String> {
    let m = i.mnemonic.trim_end_matches(".w");
    let ops = i.operands.as_str();
    if m == "push" || m == "vpush" || ((m == "stmdb" || m == "vstmdb") && ops.starts_with("sp!")) {
        let (n, w) = reg_list(ops);
        return Ok(n * w);
    }
    let first = ops.split(',').next().unwrap_or("").trim();
    // Pre-indexed single stores to sp (`str r4, [sp, #-8]!`).
    if (m.starts_with("str") || m.starts_with("vstr")) && ops.contains("[sp, #-") && ops.ends_with("]!") {
        let n = ops.rsplit("#-").next().and_then(|s| s.trim_end_matches("]!").parse::<u32>().ok());
        return n.ok_or_else(|| format!("unparsed sp store `{m} {ops}`"));
    }
    if first == "sp" {
        if m.starts_with("sub") {
            // `sub sp, #N`, `sub.w sp, sp, #N`, `subw sp, sp, #N`; anything else is dynamic.
            if let Some(n) = ops.rsplit_once('#').and_then(|(_, n)| n.trim().parse::<u32>().ok()) {
                return Ok(n);
            }
            return Err(format!("dynamic stack allocation `{} {ops}` at {:#x}", i.mnemonic, i.addr));
        }
        if m.starts_with("add") || m == "ldr" || m.starts_with("pop") || m.starts_with("ldm") || m.starts_with("vpop") {
            return Ok(0);
        }
        if m.starts_with("mov") || m.starts_with("bic") || m.starts_with("and") {
            return Err(format!("stack pointer set from a register `{} {ops}` at {:#x}", i.mnemonic, i.addr));
        }
    }
    Ok(0)
}

/// Indirect calls resolved by hand: in a function whose name contains `caller`, every
/// indirect call may reach the address-taken functions whose names contain one of
/// `targets`. `why` is the argument that the list is complete (kept with the rule).
#[derive(Debug, Clone)]
pub struct IndirectRule {
    pub caller: &'static str,
    pub targets: &'static [&'static str],
    pub why: &'static str,
}

/// The call graph with every edge resolved.
#[derive(Debug)]
pub struct Graph {
    /// Callees of each function (direct, tail and resolved indirect).
    pub edges: Vec<BTreeSet<usize>>,
    /// Indirect call sites (function, address) per function.
    pub indirect: Vec<Vec<u32>>,
    /// Index of the rule that resolves the indirect calls of each function, if any.
    pub rule_of: Vec<Option<usize>>,
    /// Rules that resolved to no address-taken function (stale).
    pub empty_rules: Vec<usize>,
}

impl Graph {
    /// `cut`: addresses of call/branch instructions whose edge is dropped (calls proved
    /// impossible, see `firmware::Allowed`).
    pub fn build(p: &Program, rules: &[IndirectRule], cut: &BTreeSet<u32>) -> Graph {
        let n = p.funcs.len();
        let mut edges = vec![BTreeSet::new(); n];
        let mut indirect = vec![Vec::new(); n];
        let mut rule_of = vec![None; n];
        let taken: Vec<usize> = (0..n).filter(|&i| p.address_taken.contains(&(p.funcs[i].start | 1))).collect();
        let targets_of: Vec<BTreeSet<usize>> = rules
            .iter()
            .map(|r| taken.iter().copied().filter(|&t| r.targets.iter().any(|pat| p.funcs[t].matches(pat))).collect())
            .collect();
        for (f, insns) in p.code.iter().enumerate() {
            for i in insns {
                match flow(i) {
                    Flow::Call(t) | Flow::Branch(t) if !cut.contains(&i.addr) => {
                        if let Some(g) = p.func_at(t) {
                            // A branch inside the function is control flow, not a call.
                            if g != f || matches!(flow(i), Flow::Call(_)) && t == p.funcs[g].start {
                                edges[f].insert(g);
                            }
                        }
                    }
                    Flow::Indirect => indirect[f].push(i.addr),
                    Flow::Call(_) | Flow::Branch(_) | Flow::None => {}
                }
            }
            if !indirect[f].is_empty()
                && let Some(r) = rules.iter().position(|r| p.funcs[f].matches(r.caller))
            {
                rule_of[f] = Some(r);
                edges[f].extend(targets_of[r].iter().copied());
            }
        }
        let empty_rules = (0..rules.len()).filter(|&r| targets_of[r].is_empty()).collect();
        Graph { edges, indirect, rule_of, empty_rules }
    }

    /// Functions reachable from `roots`, with the predecessor on one shortest path (BFS).
    pub fn reach(&self, roots: &[usize]) -> BTreeMap<usize, Option<usize>> {
        let mut pred: BTreeMap<usize, Option<usize>> = roots.iter().map(|&r| (r, None)).collect();
        let mut queue: std::collections::VecDeque<usize> = roots.iter().copied().collect();
        while let Some(f) = queue.pop_front() {
            for &g in &self.edges[f] {
                if let std::collections::btree_map::Entry::Vacant(e) = pred.entry(g) {
                    e.insert(Some(f));
                    queue.push_back(g);
                }
            }
        }
        pred
    }
}

/// A call path `root → … → f` (from `reach`'s predecessors).
pub fn path_to(p: &Program, pred: &BTreeMap<usize, Option<usize>>, f: usize) -> String {
    let mut chain = vec![f];
    let mut cur = f;
    while let Some(Some(prev)) = pred.get(&cur) {
        chain.push(*prev);
        cur = *prev;
        if chain.len() > 200 {
            break;
        }
    }
    chain.iter().rev().map(|&i| p.funcs[i].base_name()).collect::<Vec<_>>().join("\n    -> ")
}

/// Names of the panic / abort family (matched on the name without hash).
pub const PANIC_PATTERNS: &[&str] = &[
    "core::panicking::",
    "rust_begin_unwind",
    "core::option::unwrap_failed",
    "core::option::expect_failed",
    "core::result::unwrap_failed",
    "core::cell::panic_already_borrowed",
    "core::cell::panic_already_mutably_borrowed",
    "core::slice::index::",
    "core::str::slice_error_fail",
    "core::panic::",
    "_defmt_panic",
    "__defmt_default_panic",
    "__aeabi_idiv0",
    "__aeabi_ldiv0",
    "panic_probe::",
];

pub fn is_panic(f: &Func) -> bool {
    let hit = |n: &str| {
        let n = strip_hash(n);
        // Of `core::slice::index`, only the `*_fail` functions panic.
        let slice_ok = !n.starts_with("core::slice::index::") || n.ends_with("_fail");
        slice_ok && PANIC_PATTERNS.iter().any(|p| n.contains(p))
    };
    hit(&f.name) || f.aliases.iter().any(|a| hit(a))
}

/// Result of the panic check: every panic-family function reachable from the roots, with
/// one call path each.
pub fn reachable_panics(p: &Program, g: &Graph, roots: &[usize]) -> Vec<String> {
    let pred = g.reach(roots);
    pred.keys().filter(|&&f| is_panic(&p.funcs[f])).map(|&f| path_to(p, &pred, f)).collect()
}

/// Indirect calls in the reachable set without a rule.
pub fn unresolved_indirect(p: &Program, g: &Graph, roots: &[usize]) -> Vec<String> {
    let pred = g.reach(roots);
    let mut out = Vec::new();
    for &f in pred.keys() {
        if !g.indirect[f].is_empty() && g.rule_of[f].is_none() {
            let sites: Vec<String> = g.indirect[f].iter().map(|a| format!("{a:#x}")).collect();
            out.push(format!(
                "{} (indirect at {}); path:\n    {}",
                p.funcs[f].name,
                sites.join(", "),
                path_to(p, &pred, f)
            ));
        }
    }
    out
}

/// Recursion accepted with a bound: in a strongly connected component of the call graph
/// that contains `anchor`, at most `max_depth` frames of `anchor` are live at once, and
/// the component without `anchor` is acyclic (checked), so each level between two
/// `anchor` frames holds every member at most once: stack ≤ `max_depth` × Σ member frames
/// + the deepest call leaving the component.
#[derive(Debug, Clone)]
pub struct RecursionBound {
    pub anchor: &'static str,
    pub max_depth: u32,
    pub why: &'static str,
}

/// Worst-case stack of every function (own frame + deepest callee), bytes.
#[derive(Debug)]
pub struct Stack {
    pub frame: Vec<Result<u32, String>>,
    pub depth: Vec<Result<u32, String>>,
    /// The deepest callee chosen for each function (for the report).
    pub next: Vec<Option<usize>>,
    /// Bounded recursions found: (members, rule index, bytes of the component itself).
    pub recursions: Vec<(Vec<usize>, usize, u32)>,
}

/// Strongly connected components (Tarjan), callees before callers.
fn sccs(n: usize, succ: &dyn Fn(usize) -> Vec<usize>) -> Vec<Vec<usize>> {
    struct T<'a> {
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        out: Vec<Vec<usize>>,
        succ: &'a dyn Fn(usize) -> Vec<usize>,
    }
    fn visit(t: &mut T<'_>, v: usize) {
        t.index[v] = Some(t.next);
        t.low[v] = t.next;
        t.next += 1;
        t.stack.push(v);
        t.on[v] = true;
        for w in (t.succ)(v) {
            match t.index[w] {
                None => {
                    visit(t, w);
                    t.low[v] = t.low[v].min(t.low[w]);
                }
                Some(iw) if t.on[w] => t.low[v] = t.low[v].min(iw),
                Some(_) => {}
            }
        }
        if Some(t.low[v]) == t.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on[w] = false;
                comp.push(w);
                if w == v {
                    break;
                }
            }
            t.out.push(comp);
        }
    }
    let mut t = T {
        index: vec![None; n],
        low: vec![0; n],
        on: vec![false; n],
        stack: Vec::new(),
        next: 0,
        out: Vec::new(),
        succ,
    };
    for v in 0..n {
        if t.index[v].is_none() {
            visit(&mut t, v);
        }
    }
    t.out
}

impl Stack {
    /// `stop`: functions not descended into (terminal paths, e.g. the panic handler); their
    /// own frame still counts.
    pub fn compute(p: &Program, g: &Graph, stop: &BTreeSet<usize>, bounds: &[RecursionBound]) -> Stack {
        let n = p.funcs.len();
        let frame: Vec<Result<u32, String>> = p
            .code
            .iter()
            .zip(&p.funcs)
            .map(|(insns, f)| {
                insns
                    .iter()
                    .try_fold(0u32, |acc, i| stack_alloc(i).map(|b| acc + b))
                    .map_err(|e| format!("{}: {e}", f.name))
            })
            .collect();
        let succ = |f: usize| -> Vec<usize> {
            if stop.contains(&f) { Vec::new() } else { g.edges[f].iter().copied().collect() }
        };
        let mut s =
            Stack { frame, depth: vec![Err("not computed".into()); n], next: vec![None; n], recursions: Vec::new() };
        for comp in sccs(n, &succ) {
            let members: BTreeSet<usize> = comp.iter().copied().collect();
            let recursive = comp.len() > 1 || succ(comp[0]).contains(&comp[0]);
            // Own cost of the component.
            let own: Result<u32, String> = if !recursive {
                s.frame[comp[0]].clone()
            } else {
                let names: Vec<&str> = comp.iter().map(|&f| p.funcs[f].base_name()).collect();
                let rule = bounds.iter().position(|b| comp.iter().any(|&f| p.funcs[f].matches(b.anchor)));
                match rule {
                    None => Err(format!("recursion through {}", names.join(", "))),
                    Some(r) => {
                        let anchor: BTreeSet<usize> =
                            comp.iter().copied().filter(|&f| p.funcs[f].matches(bounds[r].anchor)).collect();
                        // The component without the anchor must be acyclic.
                        let inner = |f: usize| -> Vec<usize> {
                            if anchor.contains(&f) {
                                Vec::new()
                            } else {
                                succ(f).into_iter().filter(|c| members.contains(c) && !anchor.contains(c)).collect()
                            }
                        };
                        let cyclic = sccs(n, &|f| if members.contains(&f) { inner(f) } else { Vec::new() })
                            .iter()
                            .any(|c| c.len() > 1 || inner(c[0]).contains(&c[0]));
                        let sum: Result<u32, String> =
                            comp.iter().try_fold(0u32, |a, &f| s.frame[f].clone().map(|b| a + b));
                        if cyclic {
                            Err(format!("recursion through {} not only via {}", names.join(", "), bounds[r].anchor))
                        } else {
                            sum.map(|b| {
                                let bytes = b * bounds[r].max_depth;
                                s.recursions.push((comp.clone(), r, bytes));
                                bytes
                            })
                        }
                    }
                }
            };
            // Deepest call leaving the component (callees are done: Tarjan order).
            let mut deepest: Result<(u32, Option<usize>), String> = Ok((0, None));
            for &f in &comp {
                for c in succ(f) {
                    if members.contains(&c) {
                        continue;
                    }
                    deepest = match (deepest, &s.depth[c]) {
                        (Err(e), _) => Err(e),
                        (Ok(_), Err(e)) => Err(format!("{e}\n    <- {}", p.funcs[f].base_name())),
                        (Ok((d, w)), Ok(dc)) => Ok(if *dc >= d { (*dc, Some(c)) } else { (d, w) }),
                    };
                }
            }
            let total = own.and_then(|o| deepest.clone().map(|(d, _)| o + d));
            let next = deepest.ok().and_then(|(_, w)| w);
            for &f in &comp {
                s.depth[f] = total.clone();
                s.next[f] = next;
            }
        }
        s
    }

    /// The deepest chain from `f`, one `frame name` line each.
    pub fn chain(&self, p: &Program, f: usize) -> String {
        let mut out = String::new();
        let mut cur = Some(f);
        let mut guard = 0;
        while let Some(c) = cur {
            let fr = self.frame[c].as_ref().map_or(0, |b| *b);
            let rec = self
                .recursions
                .iter()
                .find(|(m, _, _)| m.contains(&c))
                .map_or(String::new(), |(_, _, b)| format!("  (bounded recursion: {b} B)"));
            let _ = writeln!(out, "    {fr:>6} B  {}{rec}", p.funcs[c].base_name());
            cur = self.next[c];
            guard += 1;
            if guard > 500 {
                break;
            }
        }
        out
    }
}

/// ARMv7-M exception entry with the FPU context (lazy stacking reserves it whenever the
/// interrupted context used the FPU): 26 words, plus 4 bytes of alignment padding
/// (ARMv7-M ARM B1.5.7, CCR.STKALIGN = 1).
pub const EXCEPTION_FRAME_FP: u32 = 26 * 4 + 4;

#[cfg(test)]
mod tests;

mod firmware;
pub use firmware::{Analysis, Board, SCHEMA_MAX_DEPTH};
