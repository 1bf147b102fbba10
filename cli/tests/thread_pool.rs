//! `lfdepth estimate --threads N` starts N worker threads once: the views are decoded
//! and every stage runs on the same pool (one test in this binary, so no other test's
//! pools are counted), and the map is the same bits for 1, 2 and 3 threads, on a
//! rectified array (the range runs beside the alignment's check) and on a misaligned
//! one (the views are warped in the pool).

mod common;

use clap::Parser;
use common::{arg, synth_scene, temp};
use lfdepth_cli::commands::{self, Cli};
use lfdepth_cli::engine;

/// Runs `lfdepth estimate SCENE -o OUT --threads THREADS` in this process and returns
/// the worker threads it started and the map's bit patterns.
fn estimate(scene: &std::path::Path, out: &std::path::Path, threads: usize) -> (usize, Vec<u32>) {
    let threads = threads.to_string();
    let cli = Cli::try_parse_from([
        "lfdepth",
        "estimate",
        arg(scene),
        "-o",
        arg(out),
        "--quiet",
        "--threads",
        &threads,
    ])
    .expect("the arguments parse");
    let before = engine::threads_started();
    commands::run(cli).expect("estimate succeeds");
    let started = engine::threads_started() - before;
    let bits = lfdepth_cli::io::pfm::read(out)
        .unwrap()
        .data
        .iter()
        .map(|v| v.to_bits())
        .collect();
    (started, bits)
}

#[test]
fn one_pool_serves_the_load_and_the_stages_and_the_map_does_not_depend_on_it() {
    let dir = temp();
    for (name, flags) in [("rectified", &[][..]), ("misaligned", &["--misalign"][..])] {
        let scene = synth_scene(
            &dir.path().join(name),
            "mixed",
            64,
            &[&["--grid", "5x5"][..], flags].concat(),
        );
        let out = dir.path().join(format!("{name}.pfm"));
        let (_, one) = estimate(&scene, &out, 1);
        for threads in 1..=3 {
            let (started, bits) = estimate(&scene, &out, threads);
            assert_eq!(
                started, threads,
                "{name}: --threads {threads} started {started} worker threads"
            );
            assert!(
                bits == one,
                "{name}: the map with {threads} threads differs from one thread's"
            );
        }
    }
}
