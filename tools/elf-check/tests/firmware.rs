//! elf-check on the real firmware images (both boards). `scripts/firmware.sh` is run first
//! (incremental: about a second when the images are current), so the images analysed are
//! the ones of this source tree.
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Once;

use elf_check::{Analysis, Board, SCHEMA_MAX_DEPTH};

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn image(board: &str) -> PathBuf {
    static BUILT: Once = Once::new();
    BUILT.call_once(|| {
        for cmd in ["build", "build-stm32"] {
            let st = Command::new(repo().join("scripts/firmware.sh"))
                .arg(cmd)
                .stdout(Stdio::null())
                .status()
                .expect("scripts/firmware.sh");
            assert!(st.success(), "scripts/firmware.sh {cmd} failed");
        }
    });
    let fw = repo().join("firmware/target");
    match board {
        "qemu" => fw.join("thumbv7em-none-eabihf/release/acs-firmware"),
        _ => fw.join("stm32f405/thumbv7em-none-eabihf/release/acs-firmware"),
    }
}

/// No panic reachable from the tasks and interrupt handlers, every indirect call resolved,
/// no unbounded recursion or dynamic stack frame, and the stack bound (thread + every
/// handler at its own priority) within half of the stack region.
#[test]
fn both_images_pass_the_static_checks() {
    for name in ["qemu", "stm32"] {
        let board = Board::named(name).unwrap();
        let a = Analysis::of_elf(&board, &image(name)).unwrap();
        eprintln!("{}", a.report);
        assert!(a.errors.is_empty(), "{name}: {:#?}", a.errors);
        // The deepest thread chain goes through the link task's parameter upload
        // (`Configured::build`): a bound without it would be missing a path.
        assert!(a.report.contains("acs_flight::fsw::config::<impl acs_flight::fsw::Configured>::build"), "{name}");
        assert!(a.bound > 20_000 && a.bound < 64 * 1024, "{name}: bound {}", a.bound);
    }
}

/// The check catches real panics in the real image: without the proofs of impossible
/// library panics, the thread-mode assertion of embassy-sync's mutex (in both tasks) and
/// the defmt logger's re-entrancy check are reported, each with its call path.
#[test]
fn without_the_proofs_the_library_panics_are_reported() {
    let mut board = Board::named("qemu").unwrap();
    board.allowed = &[];
    let a = Analysis::of_elf(&board, &image("qemu")).unwrap();
    let panics: Vec<&String> = a.errors.iter().filter(|e| e.starts_with("panic reachable:")).collect();
    assert!(panics.len() >= 10, "{panics:#?}");
    assert!(panics.iter().any(|e| e.contains("embassy-sync-0.8.0/src/blocking_mutex/raw.rs:120")));
    assert!(panics.iter().any(|e| e.contains("defmt-semihosting-0.4.0/src/lib.rs:69")));
    assert!(panics.iter().any(|e| e.contains("path: embassy_executor::raw::TaskStorage<F>::poll")));
}

/// Nesting depth of a schema: the number of `NamedType::serialize` frames live at once
/// when `schema_hash` serializes it.
fn depth(t: &postcard_schema::schema::NamedType) -> u32 {
    use postcard_schema::schema::{DataModelType as T, DataModelVariant as V};
    let children: Vec<&postcard_schema::schema::NamedType> = match t.ty {
        T::Option(c) | T::NewtypeStruct(c) | T::Seq(c) => vec![c],
        T::Tuple(cs) | T::TupleStruct(cs) => cs.to_vec(),
        T::Map { key, val } => vec![key, val],
        T::Struct(vs) => vs.iter().map(|v| v.ty).collect(),
        T::Enum(vs) => vs
            .iter()
            .flat_map(|v| match v.ty {
                V::UnitVariant => vec![],
                V::NewtypeVariant(c) => vec![*c],
                V::TupleVariant(cs) => cs.to_vec(),
                V::StructVariant(vs) => vs.iter().map(|v| v.ty).collect(),
            })
            .collect(),
        _ => vec![],
    };
    1 + children.into_iter().map(depth).max().unwrap_or(0)
}

/// The recursion bound elf-check uses for `schema_hash` covers the message types.
#[test]
fn schema_depth_is_within_the_recursion_bound() {
    use postcard_schema::Schema;
    let d = depth(acs_flight::link::HostMsg::SCHEMA).max(depth(acs_flight::link::FswMsg::SCHEMA));
    eprintln!("schema nesting depth {d}, bound {SCHEMA_MAX_DEPTH}");
    assert!(d >= 3, "HostMsg -> variant -> struct field nests at least 3 deep, got {d}");
    assert!(d <= SCHEMA_MAX_DEPTH, "schema depth {d} > SCHEMA_MAX_DEPTH {SCHEMA_MAX_DEPTH}: raise it in firmware.rs");
}
