//! The acs-firmware images: roots, indirect-call rules, RAM limits, and the report.
use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use crate::{
    EXCEPTION_FRAME_FP, Flow, Graph, IndirectRule, Program, RecursionBound, Stack, flow, is_panic, path_to,
    reachable_panics, unresolved_indirect,
};

/// Per-board configuration.
pub struct Board {
    pub name: &'static str,
    /// Roots of the panic check (name patterns without hash; each must match a function).
    pub panic_roots: &'static [&'static str],
    /// Vector-table handlers that end the program (fault reporting): excluded from the
    /// panic check and from the nesting sum (they never return to the code they interrupt).
    pub terminal_handlers: &'static [&'static str],
    pub rules: &'static [IndirectRule],
    /// Number of embassy task poll functions expected (link and control task).
    pub tasks: usize,
    /// Panic call sites proved unreachable (see [`Allowed`]).
    pub allowed: &'static [&'static [Allowed]],
    pub recursion: &'static [RecursionBound],
}

/// A call into the panic family that cannot execute, with the proof. A call site is
/// accepted when every source location that leads to it (the call instruction and the
/// branches into its basic block, each with its inlining chain from `llvm-addr2line -i`;
/// locations at line 0 carry no information and are skipped) contains `at`, for an entry
/// whose `callee` matches (`at` lists `file:line`s; empty: any site of that callee). Crate versions are
/// part of `at` on purpose: an upgrade must be re-reviewed.
pub struct Allowed {
    pub callee: &'static str,
    pub at: &'static [&'static str],
    pub proof: &'static str,
}

/// Indirect calls of embassy-executor and its users. Every `blx` below loads its target
/// from a `core::task::RawWakerVTable` (offsets 0 clone, 4 wake, 8 wake_by_ref, 12 drop)
/// or, in the executor loop, from the task header's `poll_fn`. The only waker vtable in
/// the image is embassy-executor's (`raw::waker::VTABLE`: embassy-time's queue even checks
/// the vtable pointer), and the only task poll functions are the `TaskStorage<F>::poll`
/// instances of the firmware's tasks; `Analysis::check` verifies both claims on the
/// address-taken set (no other address-taken function named `wake`/`poll`).
const WAKER_TARGETS: &[&str] = &["embassy_executor::raw::waker::"];
const WAKER_WHY: &str = "waker vtable call (AtomicWaker/WakerRegistration/Mutex/Signal/timer queue)";
const RULES: &[IndirectRule] = &[
    IndirectRule {
        caller: "acs_firmware::executor::Executor::run",
        targets: &["embassy_executor::raw::TaskStorage<F>::poll"],
        why: "SyncExecutor::poll (inlined) calls the task header's poll_fn",
    },
    IndirectRule { caller: "embassy_executor::raw::TaskStorage<F>::poll", targets: WAKER_TARGETS, why: WAKER_WHY },
    IndirectRule { caller: "acs_firmware::state::send::", targets: WAKER_TARGETS, why: WAKER_WHY },
    IndirectRule {
        caller: "core::ptr::drop_in_place<embassy_sync::mutex::MutexGuard",
        targets: WAKER_TARGETS,
        why: WAKER_WHY,
    },
    IndirectRule { caller: "_embassy_time_schedule_wake", targets: WAKER_TARGETS, why: WAKER_WHY },
    // `Signal::wait` kept out of line by the control task's `select` (watchdog keep-alive
    // while waiting for StartRealTime): embassy-sync signal.rs:90-115 clones, wakes and
    // drops the stored waker (checked by disassembly: every `blx` loads from a
    // RawWakerVTable slot).
    IndirectRule {
        caller: "<core::future::poll_fn::PollFn<F> as core::future::future::Future>::poll",
        targets: WAKER_TARGETS,
        why: WAKER_WHY,
    },
    IndirectRule { caller: "SysTick", targets: WAKER_TARGETS, why: WAKER_WHY },
    IndirectRule { caller: "acs_firmware::board::qemu::uart0_rx_isr", targets: WAKER_TARGETS, why: WAKER_WHY },
    IndirectRule { caller: "acs_firmware::board::qemu::uart0_tx_isr", targets: WAKER_TARGETS, why: WAKER_WHY },
    // STM32F405: embassy-stm32's USART2 (BufferedUart) and TIM12 (time driver) handlers.
    IndirectRule { caller: "USART2", targets: WAKER_TARGETS, why: WAKER_WHY },
    IndirectRule { caller: "TIM8_BRK_TIM12", targets: WAKER_TARGETS, why: WAKER_WHY },
    IndirectRule {
        caller: "_defmt_",
        targets: &["defmt_rtt::channel::Channel::"],
        why: "defmt-rtt calls Channel::blocking_write or nonblocking_write through a function \
              pointer chosen by the RTT mode (the only address-taken functions of defmt_rtt)",
    },
];

/// Where the flight code runs: both task poll functions (the link task inlines
/// `Session::handle`, hence lockstep `Fsw::step`; the control task calls
/// `state::measured_step`), `Fsw::step` itself (an out-of-line function with LTO, checked
/// on its own so that it stays covered if the tasks change).
const FLIGHT_ROOTS: &[&str] = &[
    "embassy_executor::raw::TaskStorage<F>::poll",
    "acs_flight::fsw::Fsw::step",
    "acs_firmware::state::measured_step",
];

/// Panic sites in library code that cannot execute in this firmware.
const ALLOWED: &[Allowed] = &[
    Allowed {
        callee: "core::panicking::panic_const::panic_const_async_fn_resumed",
        at: &[],
        proof: "an async state machine is never polled after it returned Ready: embassy's \
                TaskStorage::poll despawns the task on Ready, and every inner future is \
                awaited, i.e. dropped by its parent state machine when it completes",
    },
    Allowed {
        callee: "__defmt_default_panic",
        at: &["embassy-sync-0.8.0/src/blocking_mutex/raw.rs:120"],
        proof: "ThreadModeRawMutex::lock asserts thread mode: the only locks are the \
                SharedSession/SharedTx mutexes and the task signals, taken by the two tasks, \
                which the executor polls from main (thread mode); no interrupt handler \
                touches them (board ISRs only use atomics and AtomicWaker)",
    },
    Allowed {
        callee: "__defmt_default_panic",
        at: &["embassy-sync-0.8.0/src/mutex.rs:210"],
        proof: "MutexGuard::drop re-locks the raw mutex: same thread-mode argument as raw.rs:120",
    },
    Allowed {
        callee: "__defmt_default_panic",
        at: &["embassy-executor-0.10.0/src/raw/waker.rs:35", "embassy-executor-0.10.0/src/raw/waker.rs:44"],
        proof: "task_from_waker rejects foreign wakers; the only waker vtable whose address \
                is taken in the image is embassy-executor's (checked by the rules check)",
    },
    Allowed {
        callee: "core::cell::panic_already_borrowed",
        at: &["embassy-sync-0.8.0/src/mutex.rs:80"],
        proof: "Mutex::lock borrows its RefCell inside the blocking mutex's closure only and \
                calls nothing that could lock the same mutex, so the borrow cannot nest",
    },
    Allowed {
        callee: "core::panicking::panic_fmt",
        at: &["defmt-semihosting-0.4.0/src/lib.rs:68", "defmt-semihosting-0.4.0/src/lib.rs:69"],
        proof: "'logger taken reentrantly': acquire() enters a critical section (interrupts \
                masked, one core) before the check and release() leaves it after clearing \
                the flag, so nothing can run between them; QEMU logger only",
    },
    Allowed {
        callee: "core::panicking::panic_fmt",
        at: &["defmt-semihosting-0.4.0/src/lib.rs:94", "defmt-semihosting-0.4.0/src/lib.rs:95"],
        proof: "'release out of context': defmt pairs every release with a preceding acquire",
    },
    Allowed {
        callee: "core::panicking::panic_fmt",
        at: &["defmt-semihosting-0.4.0/src/lib.rs:117", "defmt-semihosting-0.4.0/src/lib.rs:118"],
        proof: "'write out of context': defmt only writes between acquire and release",
    },
    Allowed {
        callee: "core::panicking::panic",
        at: &["semihosting-0.1.25/src/fd.rs:70"],
        proof: "BorrowedFd::borrow_raw asserts fd != -1; the fd comes from an OwnedFd, which \
                semihosting only builds from a successful open (-1 is returned as Err)",
    },
];

/// Panic sites of the STM32 libraries (embassy-stm32 0.6 buffered USART and time driver,
/// embedded-io-async, defmt-rtt) that cannot execute.
const ALLOWED_STM32: &[Allowed] = &[
    Allowed {
        callee: "core::slice::index::",
        at: &["embassy-stm32-0.6.0/src/usart/buffered.rs:581"],
        proof: "BufferedUartRx::read: buf[buf_len..buf_len + data_len] with \
                data_len = min(data.len(), buf.len() - buf_len), so the range is inside buf",
    },
    Allowed {
        callee: "core::slice::index::",
        at: &["embassy-stm32-0.6.0/src/usart/buffered.rs:708"],
        proof: "BufferedUartTx::write: n = min(data.len(), buf.len() - written), so data[..n] \
                and buf[written..written + n] are in range",
    },
    Allowed {
        callee: "core::panicking::panic_fmt",
        at: &["embedded-io-async-0.7.0/src/lib.rs:143", "embassy-stm32-0.6.0/src/usart/buffered.rs:0"],
        proof: "write_all panics on Ok(0); BufferedUartTx::write only returns Ready(Ok(n)) \
                after its loop copied all of a non-empty buf (it is Pending while the ring is \
                full), and write_all only calls it with a non-empty buf",
    },
    Allowed {
        callee: "core::slice::index::",
        at: &["embedded-io-async-0.7.0/src/lib.rs:144"],
        proof: "write_all: buf = &buf[n..] with n returned by write, n <= buf.len() (see :143)",
    },
    Allowed {
        callee: "core::cell::panic_already_borrowed",
        at: &[
            "embassy-stm32-0.6.0/src/time_driver/gp16.rs:216",
            "embassy-stm32-0.6.0/src/time_driver/gp16.rs:218",
            "embassy-stm32-0.6.0/src/time_driver/gp16.rs:358",
        ],
        proof: "the time driver's queue RefCell is only borrowed inside critical sections \
                (one core, interrupts masked) and each borrow ends before the next one; \
                next_expiration/set_alarm do not borrow it again",
    },
    Allowed {
        callee: "core::panicking::panic_fmt",
        at: &["defmt-rtt-1.3.1/src/lib.rs:172", "defmt-rtt-1.3.1/src/lib.rs:173"],
        proof: "'logger taken reentrantly': acquire() holds a critical section from before the \
                check until release(), as in defmt-semihosting",
    },
    Allowed {
        callee: "core::panicking::panic_fmt",
        at: &["defmt-rtt-1.3.1/src/lib.rs:225", "defmt-rtt-1.3.1/src/lib.rs:226"],
        proof: "'release out of context': defmt pairs every release with a preceding acquire",
    },
];

/// `acs_flight::link::schema_hash` serializes the message schemas (postcard-schema's
/// `NamedType` tree) to hash them: the recursion depth is the nesting depth of the
/// message types, a compile-time constant checked by the `schema_depth` test.
pub const SCHEMA_MAX_DEPTH: u32 = 12;
const RECURSION: &[RecursionBound] = &[RecursionBound {
    anchor: "postcard_schema::schema::_::<impl serde_core::ser::Serialize for postcard_schema::schema::NamedType>::serialize",
    max_depth: SCHEMA_MAX_DEPTH,
    why: "schema nesting depth of HostMsg/FswMsg (test schema_depth)",
}];

impl Board {
    pub fn named(name: &str) -> Option<Board> {
        match name {
            "qemu" => Some(Board {
                name: "qemu-mps2-an386",
                panic_roots: FLIGHT_ROOTS,
                terminal_handlers: &["HardFault", "DefaultHandler", "acs_firmware::board::qemu::unexpected_irq"],
                rules: RULES,
                tasks: 2,
                allowed: &[ALLOWED],
                recursion: RECURSION,
            }),
            "stm32" => Some(Board {
                name: "stm32f405",
                panic_roots: FLIGHT_ROOTS,
                terminal_handlers: &["HardFault", "DefaultHandler"],
                rules: RULES,
                tasks: 2,
                allowed: &[ALLOWED, ALLOWED_STM32],
                recursion: RECURSION,
            }),
            _ => None,
        }
    }
}

pub struct Analysis {
    pub program: Program,
    pub graph: Graph,
    pub report: String,
    pub errors: Vec<String>,
    /// Static stack bound (thread + all handlers), bytes.
    pub bound: u32,
    /// Direct calls into the panic family from reachable code: (address, caller -> callee).
    pub panic_sites: Vec<(u32, String)>,
}

fn run(tool: &str, args: &[&str]) -> Result<String, String> {
    let out = Command::new(tool)
        .args(args)
        .output()
        .map_err(|e| format!("cannot run {tool}: {e} (scripts/setup.sh installs the Debian package `llvm`)"))?;
    if !out.status.success() {
        return Err(format!("{tool} {args:?} failed: {}", String::from_utf8_lossy(&out.stderr)));
    }
    String::from_utf8(out.stdout).map_err(|e| format!("{tool}: {e}"))
}

/// Inlining chains of `addrs`, one string per address (`llvm-addr2line -f -i -C -p`; an
/// answer starts with the echoed address, `-a`).
fn addr2line(elf: &str, addrs: &[u32]) -> Vec<String> {
    if addrs.is_empty() {
        return Vec::new();
    }
    let mut args: Vec<String> = ["-a", "-f", "-i", "-C", "-p", "-e", elf].iter().map(|s| s.to_string()).collect();
    args.extend(addrs.iter().map(|a| format!("{a:#x}")));
    let argv: Vec<&str> = args.iter().map(String::as_str).collect();
    let text = run("llvm-addr2line", &argv).unwrap_or_default();
    let mut out: Vec<String> = Vec::new();
    for line in text.lines() {
        // `0x1fd2: f at file:line` starts an address, ` (inlined by) g at …` continues it.
        if let Some((a, first)) = line.split_once(": ").filter(|(a, _)| a.starts_with("0x")) {
            let _ = a;
            out.push(format!("{first}\n"));
        } else if let Some(cur) = out.last_mut() {
            cur.push_str(line.trim());
            cur.push('\n');
        }
    }
    out.resize(addrs.len(), String::new());
    out
}

/// `loc` names `at` (`file:line`), not a longer line number (`:120` must not match `:1200`).
fn mentions(loc: &str, at: &str) -> bool {
    loc.match_indices(at).any(|(i, _)| !loc[i + at.len()..].starts_with(|c: char| c.is_ascii_digit()))
}

/// The innermost frame (first line) is at line 0: compiler-generated, no source statement.
fn innermost_line_zero(loc: &str) -> bool {
    loc.lines().next().is_none_or(|l| l.trim_end().ends_with(":0") || l.contains(":0 (discriminator"))
}

impl Analysis {
    pub fn of_elf(board: &Board, elf: &Path) -> Result<Analysis, String> {
        let elf = elf.to_str().ok_or("ELF path is not UTF-8")?;
        let nm = run("llvm-nm", &["-S", "-n", "--defined-only", "-C", elf])?;
        let dis = run("llvm-objdump", &["-d", "--no-show-raw-insn", elf])?;
        let data = run("llvm-objdump", &["-s", "-j", ".vector_table", "-j", ".rodata", "-j", ".data", elf])?;
        let program = Program::parse(&nm, &dis, &data)?;
        let locate = |addrs: &[u32]| addr2line(elf, addrs);
        Ok(Analysis::new(board, program, &locate))
    }

    /// `locate`: source locations (inlining chains) of instruction addresses.
    pub fn new(board: &Board, program: Program, locate: &dyn Fn(&[u32]) -> Vec<String>) -> Analysis {
        let graph = Graph::build(&program, board.rules, &BTreeSet::new());
        let mut a =
            Analysis { program, graph, report: String::new(), errors: Vec::new(), bound: 0, panic_sites: Vec::new() };
        a.check(board, locate);
        a
    }

    fn check(&mut self, board: &Board, locate: &dyn Fn(&[u32]) -> Vec<String>) {
        let p = &self.program;
        let g = &self.graph;
        let mut errors = Vec::new();
        let mut r = String::new();
        let _ = writeln!(
            r,
            "elf-check {}: {} functions, {} address-taken",
            board.name,
            p.funcs.len(),
            p.address_taken.len()
        );

        // Every direct branch must land in a known function.
        for insns in &p.code {
            for i in insns {
                if let Flow::Call(t) | Flow::Branch(t) = flow(i)
                    && p.func_at(t).is_none()
                {
                    errors.push(format!("branch at {:#x} to {t:#x}, outside every function", i.addr));
                }
            }
        }
        // A rule applied to an indirect call must resolve to at least one target.
        for &k in &g.empty_rules {
            if g.rule_of.contains(&Some(k)) {
                errors.push(format!(
                    "indirect-call rule for {} resolves to no address-taken function",
                    board.rules[k].caller
                ));
            }
        }
        // The claims behind the waker / poll_fn rules: no other waker or poll function has
        // its address taken.
        for &a in &p.address_taken {
            if let Some(f) = p.func_at(a) {
                let n = p.funcs[f].base_name();
                let covered = n.starts_with("embassy_executor::raw::waker::")
                    || n.starts_with("embassy_executor::raw::TaskStorage<F>::poll");
                if !covered && (n.contains("wake") || n.contains("poll") || n.contains("clone") || n.contains("drop")) {
                    errors.push(format!("address-taken {n} is not covered by the indirect-call rules"));
                }
            }
        }

        // Roots.
        let mut panic_roots = Vec::new();
        for pat in board.panic_roots {
            let found = p.find(pat);
            if found.is_empty() {
                errors.push(format!("root {pat} not found in the image (renamed or inlined?)"));
            }
            panic_roots.extend(found);
        }
        let tasks = p.find("embassy_executor::raw::TaskStorage<F>::poll");
        if tasks.len() != board.tasks {
            errors.push(format!("expected {} task poll functions (link, control), found {}", board.tasks, tasks.len()));
        }
        let terminal: BTreeSet<usize> = board.terminal_handlers.iter().flat_map(|t| p.find(t)).collect();
        // Thread mode starts at the reset vector (entry 1).
        let reset: Vec<usize> = p.vectors.iter().filter(|(n, _)| *n == 1).filter_map(|&(_, h)| p.func_at(h)).collect();
        if reset.is_empty() {
            errors.push("no reset vector".into());
        }
        let mut handlers: Vec<(u32, usize)> = Vec::new(); // (exception number, function)
        for &(n, h) in &p.vectors {
            match p.func_at(h) {
                Some(f) if p.funcs[f].start == h => {
                    if n != 1 && !terminal.contains(&f) && !handlers.iter().any(|&(_, g)| g == f) {
                        handlers.push((n, f));
                    }
                }
                _ => errors.push(format!("vector {n} points to {h:#x}, not a function entry")),
            }
        }
        let mut roots_all = panic_roots.clone();
        roots_all.extend(handlers.iter().map(|&(_, f)| f));
        let _ = writeln!(r, "panic-check roots:");
        for &f in &roots_all {
            let _ = writeln!(r, "    {}", p.funcs[f].name);
        }

        // Panic call sites in the reachable code (full graph), their source locations, and
        // the ones proved impossible (`allowed`): those edges are cut.
        let pred_full = g.reach(&roots_all);
        let mut sites: Vec<(u32, usize, usize, Vec<u32>)> = Vec::new(); // (addr, caller, callee, keys)
        for &f in pred_full.keys() {
            if is_panic(&p.funcs[f]) {
                continue;
            }
            let code = &p.code[f];
            for (k, i) in code.iter().enumerate() {
                let (Flow::Call(t) | Flow::Branch(t)) = flow(i) else { continue };
                let Some(c) = p.func_at(t).filter(|&c| c != f && is_panic(&p.funcs[c])) else { continue };
                // The basic block ending at the call: it starts after the previous branch
                // (or return, trap, call that never returns). Its entries are the branches
                // into it and, if that previous instruction is a conditional branch, its
                // fall-through: those instructions carry the source of the check.
                let mut start = i.addr;
                let mut gate = None;
                for j in code[..k].iter().rev() {
                    let m = j.mnemonic.as_str();
                    let ends_block = match flow(j) {
                        Flow::Call(t) => p.func_at(t).is_some_and(|c| is_panic(&p.funcs[c])),
                        Flow::Indirect => !m.starts_with("blx"),
                        Flow::Branch(_) => {
                            if m.trim_end_matches(".w") != "b" {
                                gate = Some(j.addr);
                            }
                            true
                        }
                        Flow::None => {
                            (m.starts_with("pop") && j.operands.contains("pc"))
                                || m == "bx"
                                || m == "trap"
                                || m.starts_with("udf")
                        }
                    };
                    if ends_block {
                        break;
                    }
                    start = j.addr;
                }
                let mut keys = vec![i.addr];
                keys.extend(gate);
                for j in code {
                    if let Flow::Branch(t) = flow(j)
                        && (start..=i.addr).contains(&t)
                        && j.addr != i.addr
                    {
                        keys.push(j.addr);
                    }
                }
                sites.push((i.addr, f, c, keys));
            }
        }
        let all_keys: Vec<u32> = sites.iter().flat_map(|s| s.3.iter().copied()).collect();
        let locs: std::collections::HashMap<u32, String> = all_keys.iter().copied().zip(locate(&all_keys)).collect();
        let mut cut = BTreeSet::new();
        let allowed: Vec<&Allowed> = board.allowed.iter().flat_map(|l| l.iter()).collect();
        let mut used = vec![false; allowed.len()];
        for (addr, _, c, keys) in &sites {
            let callee = &p.funcs[*c];
            let informative: Vec<&String> =
                keys.iter().filter_map(|k| locs.get(k)).filter(|l| !innermost_line_zero(l)).collect();
            let entry_for = |l: Option<&String>| {
                allowed.iter().position(|a| {
                    callee.matches(a.callee)
                        && (a.at.is_empty() || l.is_some_and(|l| a.at.iter().any(|at| mentions(l, at))))
                })
            };
            let ok = if informative.is_empty() {
                entry_for(None).map(|e| vec![e])
            } else {
                informative.iter().map(|l| entry_for(Some(l))).collect::<Option<Vec<usize>>>()
            };
            if let Some(entries) = ok {
                cut.insert(*addr);
                for e in entries {
                    used[e] = true;
                }
            }
        }
        let g_cut = Graph::build(p, board.rules, &cut);
        let g = &g_cut;
        for u in unresolved_indirect(p, g, &roots_all) {
            errors.push(format!("indirect call without a rule in a reachable function: {u}"));
        }
        let pred = g.reach(&roots_all);
        let _ = writeln!(r, "reachable from the roots: {} functions; indirect calls resolved by rule:", pred.len());
        for &f in pred.keys() {
            if let Some(k) = g.rule_of[f] {
                let _ = writeln!(
                    r,
                    "    {} -> {} ({})",
                    p.funcs[f].base_name(),
                    board.rules[k].targets.join(" | "),
                    board.rules[k].why
                );
            }
        }
        let _ = writeln!(r, "panic call sites in reachable code: {}, proved impossible: {}", sites.len(), cut.len());
        for (k, a) in allowed.iter().enumerate() {
            if used[k] {
                let _ = writeln!(r, "    allowed: {} at {:?}", a.callee, a.at);
            }
        }
        for (addr, f, c, keys) in &sites {
            if cut.contains(addr) || !pred.contains_key(f) {
                continue;
            }
            let where_: Vec<String> = keys
                .iter()
                .filter_map(|k| locs.get(k).map(|l| format!("{k:#x}: {}", l.trim().replace('\n', "\n        "))))
                .collect();
            self.panic_sites.push((*addr, format!("{} -> {}", p.funcs[*f].base_name(), p.funcs[*c].base_name())));
            errors.push(format!(
                "panic reachable: {} -> {} at {addr:#x}\n    path: {}\n    source:\n      {}",
                p.funcs[*f].base_name(),
                p.funcs[*c].base_name(),
                path_to(p, &pred, *f).replace("\n    ", " "),
                where_.join("\n      ")
            ));
        }
        let panics = reachable_panics(p, g, &roots_all);
        let _ = writeln!(r, "reachable panic-family functions: {}", panics.len());
        for path in &panics {
            errors.push(format!("panic-family function reachable:\n    {path}"));
        }
        // Informational: panics reachable from Reset (boot included).
        let boot = reachable_panics(p, g, &reset);
        let _ = writeln!(
            r,
            "panic-family functions reachable from Reset (boot code included, informational): {}",
            boot.len()
        );

        // Stack. Terminal functions (panic family) are not descended into: they never return
        // to flight code.
        let stop: BTreeSet<usize> = (0..p.funcs.len()).filter(|&f| is_panic(&p.funcs[f])).collect();
        let stack = Stack::compute(p, g, &stop, board.recursion);
        for (members, k, bytes) in &stack.recursions {
            let names: Vec<&str> = members.iter().map(|&f| p.funcs[f].base_name()).collect();
            let _ = writeln!(
                r,
                "bounded recursion ({} x {} levels = {bytes} B): {}",
                board.recursion[*k].why,
                board.recursion[*k].max_depth,
                names.join(", ")
            );
        }
        let depth = |f: usize| stack.depth[f].clone();
        let _ = writeln!(r, "stack (bytes, deepest chain incl. own frame):");
        let mut thread = 0u32;
        for &f in reset.iter().chain(tasks.iter()).chain(p.find("acs_flight::fsw::Fsw::step").iter()) {
            match depth(f) {
                Ok(d) => {
                    let _ = writeln!(r, "  {:>7}  {}", d, p.funcs[f].name);
                    if reset.contains(&f) {
                        thread = d;
                    }
                }
                Err(e) => errors.push(format!("stack of {}: {e}", p.funcs[f].name)),
            }
        }
        if let Some(&f) = reset.first() {
            let _ = write!(r, "  deepest thread-mode chain:\n{}", stack.chain(p, f));
        }
        let mut handler_sum = 0u32;
        let mut handler_max = 0u32;
        for &(n, f) in &handlers {
            match depth(f) {
                Ok(d) => {
                    let with_frame = d + EXCEPTION_FRAME_FP;
                    handler_sum += with_frame;
                    handler_max = handler_max.max(with_frame);
                    let _ = writeln!(
                        r,
                        "  {:>7}  exception {n}: {} (+{EXCEPTION_FRAME_FP} B hardware frame = {with_frame})",
                        d, p.funcs[f].name
                    );
                }
                Err(e) => errors.push(format!("stack of handler {}: {e}", p.funcs[f].name)),
            }
        }
        let total = thread + handler_sum;
        let sym = |n: &str| p.symbols.get(n).copied();
        let top = sym("_stack_start").unwrap_or(p.initial_sp);
        let bottom = sym("__sheap").or_else(|| sym("__euninit")).or_else(|| sym("__ebss"));
        match bottom {
            Some(bottom) if top > bottom => {
                let avail = top - bottom;
                let _ = writeln!(
                    r,
                    "stack bound: thread {thread} + handlers {handler_sum} (every handler at its own priority; {handler_max} if they share one) = {total} B; \
                     stack region {avail} B ({bottom:#x}..{top:#x}); bound = {:.1} % of it",
                    f64::from(total) * 100.0 / f64::from(avail)
                );
                // Margin: the bound must fit in half of the stack region.
                if total.saturating_mul(2) > avail {
                    errors.push(format!("stack bound {total} B exceeds half of the {avail} B stack region"));
                }
            }
            _ => errors.push("cannot find the stack region (_stack_start, __sheap)".into()),
        }
        self.bound = total;
        self.report = r;
        self.errors = errors;
    }

    /// Source locations (with inlining) of the reachable panic call sites.
    pub fn explain(&self, elf: &Path) -> String {
        let mut out = String::new();
        for (a, what) in &self.panic_sites {
            let loc =
                run("llvm-addr2line", &["-f", "-i", "-C", "-p", "-e", elf.to_str().unwrap_or(""), &format!("{a:#x}")])
                    .unwrap_or_default();
            let _ = writeln!(out, "{a:#x} {what}\n    {}", loc.trim().replace('\n', "\n    "));
        }
        out
    }

    /// Exploration aid: every function with indirect calls, reachable or not.
    pub fn explore(&self) -> String {
        let p = &self.program;
        let mut out = String::new();
        for (f, sites) in self.graph.indirect.iter().enumerate() {
            if !sites.is_empty() {
                let _ = writeln!(out, "indirect: {} @ {:x?}", p.funcs[f].name, sites);
            }
        }
        for a in &p.address_taken {
            if let Some(f) = p.func_at(*a) {
                let _ = writeln!(out, "address-taken: {}", p.funcs[f].name);
            }
        }
        for (n, h) in &p.vectors {
            let _ = writeln!(out, "vector {n}: {}", p.func_at(*h).map_or("?", |f| p.funcs[f].name.as_str()));
        }
        out
    }
}
