//! The cargo-afl harness: `isokit-fuzz-afl TARGET` runs one of `isokit_fuzz::TARGETS` on
//! the inputs AFL++ feeds it (`tools/fuzz.sh` starts it). Built without AFL's
//! instrumentation (plain `cargo build`), it runs each file named after the target once:
//! `isokit-fuzz-afl obj crash-file`, the way to reproduce a crash.

fn main() {
    let mut args = std::env::args().skip(1);
    let name = args.next().unwrap_or_default();
    let Some(target) = isokit_fuzz::target(&name) else {
        let names: Vec<&str> = isokit_fuzz::TARGETS.iter().map(|(n, _)| *n).collect();
        eprintln!("usage: isokit-fuzz-afl TARGET [FILE...]; targets: {}", names.join(" "));
        std::process::exit(2);
    };
    let files: Vec<String> = args.collect();
    if files.is_empty() {
        afl::fuzz!(|data: &[u8]| target(data));
    } else {
        for f in files {
            target(&std::fs::read(&f).unwrap_or_else(|e| panic!("{f}: {e}")));
        }
    }
}
