//! `elf-check [--explore] <qemu|stm32> <ELF>`: panic reachability and stack bound of the
//! firmware image (see docs/elf-check.md). Exit status 1 on any violation.
use std::process::ExitCode;

use elf_check::{Analysis, Board};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let explore = args.iter().any(|a| a == "--explore");
    let args: Vec<&String> = args.iter().filter(|a| *a != "--explore").collect();
    let (Some(board), Some(elf)) = (args.first(), args.get(1)) else {
        eprintln!("usage: elf-check [--explore] <qemu|stm32> <firmware ELF>");
        return ExitCode::from(2);
    };
    let Some(board) = Board::named(board) else {
        eprintln!("unknown board {board} (qemu, stm32)");
        return ExitCode::from(2);
    };
    let analysis = match Analysis::of_elf(&board, std::path::Path::new(elf.as_str())) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("elf-check: {e}");
            return ExitCode::from(2);
        }
    };
    if explore {
        print!("{}", analysis.explore());
        print!("{}", analysis.explain(std::path::Path::new(elf.as_str())));
    }
    print!("{}", analysis.report);
    if analysis.errors.is_empty() {
        ExitCode::SUCCESS
    } else {
        for e in &analysis.errors {
            eprintln!("error: {e}");
        }
        ExitCode::FAILURE
    }
}
