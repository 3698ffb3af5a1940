//! The Cortex-M4 cycle plugin (tools/qemu-cycles, docs/timing.md "Cycles"):
//! - on a synthetic program whose cycle count is worked out by hand from the Cortex-M4
//!   TRM tables, the plugin's instruction count and both bounds equal the hand count;
//! - on the firmware, the plugin's instructions per step agree with the firmware's own
//!   cost counter, and the cycle range is consistent with the instruction count.
//!
//! Both need qemu-system-arm and a C compiler (the second also the firmware ELF): without
//! them they fail under CI and skip loudly otherwise (`support/require_tool.rs`).

#[path = "support/require_tool.rs"]
mod require_tool;

use require_tool::{Tool, require_tool};
use sim_core::scenario::Scenario;
use sim_host::cycles::{self, CyclesOptions};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The built plugin, or None (after saying why, [`require_tool`]) when the test cannot run.
fn plugin() -> Option<PathBuf> {
    require_tool(Tool::Qemu, require_tool::qemu())?;
    let p = require_tool(
        Tool::CyclePlugin,
        cycles::build_plugin().map_err(|e| format!("the cycle plugin does not build here: {e:#}")),
    )?;
    // The plugin speaks plugin API version 2 (QEMU 10.x accepts 2 … 4; 7.2 only 1); a QEMU
    // that does not accept it refuses to load it.
    let dir = tempfile::tempdir().unwrap();
    let o = qemu_synthetic(&p, 0, dir.path()).output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    if !o.status.success() && err.contains("plugin") && (err.contains("version") || err.contains("load")) {
        return require_tool(Tool::CyclePlugin, Err(format!("this QEMU does not load the cycle plugin: {err}")));
    }
    Some(p)
}

/// QEMU running [`SYNTHETIC`] with the plugin; output in `dir/out.tsv`.
fn qemu_synthetic(plugin: &Path, ws: u32, dir: &Path) -> Command {
    let img = dir.join("synthetic.bin");
    std::fs::write(&img, SYNTHETIC).unwrap();
    let mut c = Command::new("timeout");
    c.args(["20", "qemu-system-arm", "-machine", "mps2-an386", "-cpu", "cortex-m4", "-nographic", "-monitor", "none"])
        .args(["-icount", "shift=0,align=off,sleep=off", "-semihosting-config", "enable=on,target=native"])
        .arg("-plugin")
        .arg(format!("{},out={},step=0x30,ws={ws}", plugin.display(), dir.join("out.tsv").display()))
        .arg("-kernel")
        .arg(&img);
    c
}

/// tests/data/cycles-synthetic.s assembled (llvm-mc) and flattened to a raw image at 0:
/// vector table, FPU enable, `bl func`, semihosting exit; `func` at 0x30:
/// ```text
/// 30 push {r4, lr}          38 ldr r2, [sp]          40 vdiv.f32 s0, s0, s1
/// 32 movs r0, #10           3a ldr r3, [sp, #4]      44 vadd.f32 s2, s2, s3
/// 34 mov r1, sp             3c subs r0, #1           48 add.w r4, r4, #1  (×8, to 0x67)
/// 36 ldr r2, [r1]           3e bne 0x38              68 pop {r4, pc}
/// ```
const SYNTHETIC: &[u8] = &[
    0x00, 0x10, 0x00, 0x20, 0x09, 0x00, 0x00, 0x00, 0x06, 0x48, 0x4f, 0xf4, 0x70, 0x01, 0x01, 0x60, 0xbf, 0xf3, 0x4f,
    0x8f, 0xbf, 0xf3, 0x6f, 0x8f, 0x00, 0xf0, 0x0a, 0xf8, 0x18, 0x20, 0x02, 0x49, 0xab, 0xbe, 0xfe, 0xe7, 0x88, 0xed,
    0x00, 0xe0, 0x26, 0x00, 0x02, 0x00, 0x00, 0xbf, 0x00, 0xbf, 0x10, 0xb5, 0x0a, 0x20, 0x69, 0x46, 0x0a, 0x68, 0x00,
    0x9a, 0x01, 0x9b, 0x01, 0x38, 0xfb, 0xd1, 0x80, 0xee, 0x20, 0x0a, 0x31, 0xee, 0x21, 0x1a, 0x04, 0xf1, 0x01, 0x04,
    0x04, 0xf1, 0x01, 0x04, 0x04, 0xf1, 0x01, 0x04, 0x04, 0xf1, 0x01, 0x04, 0x04, 0xf1, 0x01, 0x04, 0x04, 0xf1, 0x01,
    0x04, 0x04, 0xf1, 0x01, 0x04, 0x04, 0xf1, 0x01, 0x04, 0x10, 0xbd,
];

fn run_synthetic(plugin: &Path, ws: u32) -> cycles::StepCycles {
    let dir = tempfile::tempdir().unwrap();
    let st = qemu_synthetic(plugin, ws, dir.path()).status().unwrap();
    assert!(st.success(), "qemu: {st}");
    let steps = cycles::parse_output(&std::fs::read_to_string(dir.path().join("out.tsv")).unwrap()).unwrap();
    assert_eq!(steps.len(), 1, "one call of func");
    steps.into_iter().next().unwrap()
}

/// Hand count, N = 10 loop iterations, TRM (ARM DDI 0439B) table 3-1, section 3.3.2, table 7-1:
/// - instructions: bl + push + movs + mov + ldr + 4N + vdiv + vadd + 8 add.w + pop = 56.
/// - lower (P = 1, loads pipelined): bl 1+1, push 1+2, movs 1, mov 1, ldr r2,[r1] 2 + 1
///   (its address comes from the `mov` just before: AGU stall), loop: first ldr 1
///   (pipelined after the previous ldr), later ones 2, second ldr 1, subs 1 → 10×4 − 1 = 39,
///   9 taken bne × (1+1) + 1 untaken × 1 = 19, vdiv 14, vadd 1 (an FP instruction waits
///   for the divide), 8 × add.w 1, pop 1+2+1 → 2+3+1+1+3+39+19+14+1+8+4 = 95.
/// - upper, 0 wait states (P = 3, no pipelining): bl 4, push 3, movs 1, mov 1, ldr 3,
///   N × 5 + 9 × 4 + 1 = 87, vdiv 14, vadd 1, add.w 8, pop 6 → 128.
/// - upper, 5 wait states: + 5 per taken branch (bl, 9 bne, pop: 55) + sequential fetch
///   stalls (a 16-byte line arrives 5 + 1 cycles after the previous one): the loop's line
///   0x30 runs 6 cycles from the last branch, line 0x40 runs vdiv+vadd+2 add.w = 17, line
///   0x50 runs 4 add.w = 4 < 6, so only entering 0x60 stalls, 2 cycles → 128 + 55 + 2 = 185.
#[test]
fn synthetic_program_matches_the_trm_hand_count() {
    let Some(p) = plugin() else { return };
    let s0 = run_synthetic(&p, 0);
    assert_eq!((s0.instructions, s0.cycles_lower, s0.cycles_upper), (56, 95, 128), "{s0:?}");
    assert_eq!((s0.get("taken"), s0.get("fp_div"), s0.get("load")), (11, 1, 21));
    let s5 = run_synthetic(&p, 5);
    assert_eq!((s5.instructions, s5.cycles_lower, s5.cycles_upper), (56, 95, 185), "{s5:?}");
    assert_eq!(s5.get("fetch_stall_cycles"), 2);
}

/// The firmware reads its cost counter (25 MHz: 40 instructions a tick under
/// `-icount shift=0`) before and after `Fsw::step`; the plugin counts from the call to
/// the return. The firmware's window also holds the counter reads and the argument and
/// result moves around the call (about 16 instructions in the lockstep loop, see
/// `llvm-objdump`), and the tick quantisation adds ±40: firmware − plugin ∈ [−40, 60].
#[test]
fn firmware_step_instructions_agree_with_the_cost_counter() {
    let Some(p) = plugin() else { return };
    let elf = sim_core::link::qemu::default_firmware();
    let found = if elf.exists() { Ok(()) } else { Err(format!("no firmware ELF at {}", elf.display())) };
    if require_tool(Tool::FirmwareElf, found).is_none() {
        return;
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut sc = Scenario::load(&root.join("scenarios/paper000/test3.toml")).unwrap();
    sc.duration_s = 0.5;
    let opts = CyclesOptions { plugin: Some(p), ..Default::default() };
    let (_, steps, fw) = cycles::run_scenario(&sc, None, &opts).unwrap();
    // one plugin line per firmware reply (the link pairs them step by step)
    assert!(steps.len() >= 50, "{} steps", steps.len());
    assert_eq!(fw.len(), steps.len());
    for (k, (s, f)) in steps.iter().zip(&fw).enumerate() {
        let d = f - s.instructions as f64;
        assert!((-40.0..=60.0).contains(&d), "step {k}: firmware {f} vs plugin {}", s.instructions);
        // A single-issue core needs at least a cycle per instruction, except folded ITs
        // and integer instructions hidden under a VDIV/VSQRT (a few per cent here).
        assert!(s.cycles_lower as f64 >= 0.9 * s.instructions as f64, "step {k}: {s:?}");
        assert!(s.cycles_lower <= s.cycles_upper && s.instructions <= s.cycles_upper, "step {k}: {s:?}");
    }
    eprintln!(
        "cycles: {} steps, worst {} instructions, {}–{} cycles",
        steps.len(),
        steps.iter().map(|s| s.instructions).max().unwrap(),
        steps.iter().map(|s| s.cycles_lower).max().unwrap(),
        steps.iter().map(|s| s.cycles_upper).max().unwrap()
    );
}
