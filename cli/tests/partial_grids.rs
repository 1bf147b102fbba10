//! Light fields as they come, through the binary: only the views the chosen stages read
//! must exist (the centre row and column, EPINET's cross and diagonals, a grid with a
//! corner missing), the CLI says which views it read, and an absent view a stage needs
//! is named with what would do without it.

mod common;

use std::path::Path;
use std::process::Output;

use common::{arg, assert_fails, lfdepth};

/// A synthetic 9×9 scene of `size`² in `dir/name` (views `input_CamNNN.png`).
fn synth(dir: &Path, name: &str, size: usize, extra: &[&str]) -> std::path::PathBuf {
    common::synth_scene(&dir.join(name), "mixed", size, extra)
}

/// A copy of `scene` holding only the views `keep(row, col)` accepts (and every other
/// file).
fn keep_views(scene: &Path, to: &Path, keep: impl Fn(usize, usize) -> bool) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(scene).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name().to_string_lossy().into_owned();
        let index = name
            .strip_prefix("input_Cam")
            .and_then(|n| n.strip_suffix(".png"))
            .and_then(|n| n.parse::<usize>().ok());
        if index.is_none_or(|i| keep(i / 9, i % 9)) {
            std::fs::copy(entry.path(), to.join(&name)).unwrap();
        }
    }
}

/// Which views of a 9×9 grid a folder keeps, by row and column.
type Keep = fn(usize, usize) -> bool;

fn estimate(input: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "estimate",
        arg(input),
        "-o",
        arg(out),
        "-q",
        "--threads",
        "2",
    ];
    args.extend_from_slice(extra);
    lfdepth(&args)
}

fn ok(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    stderr
}

#[test]
fn views_no_stage_reads_may_be_absent() {
    let dir = common::temp();
    let full = synth(dir.path(), "full", 48, &[]);
    let reference = dir.path().join("full.pfm");
    let said = ok(&estimate(&full, &reference, &["--align", "off"]));
    assert!(
        said.contains("reading 17 of the 9x9 views: 17 the stages read"),
        "{said}"
    );
    let reference = std::fs::read(&reference).unwrap();
    let layouts: [(&str, usize, Keep); 3] = [
        ("cross", 64, |r, c| r == 4 || c == 4),
        ("cross-and-diagonals", 48, |r, c| {
            r == 4 || c == 4 || r == c || r + c == 8
        }),
        ("corner-missing", 1, |r, c| (r, c) != (8, 8)),
    ];
    for (name, absent, keep) in layouts {
        let folder = dir.path().join(name);
        keep_views(&full, &folder, keep);
        for align in ["off", "auto"] {
            let out = dir.path().join(format!("{name}-{align}.pfm"));
            let said = ok(&estimate(&folder, &out, &["--align", align]));
            assert!(said.contains(&format!("{absent} absent")), "{name}: {said}");
            // The stages read the same views, and auto finds the array rectified.
            assert_eq!(
                std::fs::read(&out).unwrap(),
                reference,
                "{name}, --align {align}"
            );
        }
    }
}

#[test]
fn an_absent_view_a_stage_reads_is_named() {
    let dir = common::temp();
    let full = synth(dir.path(), "full", 32, &[]);
    // Row 4, column 2: on the centre row the plane sweep (and the EPI stage) reads.
    std::fs::remove_file(full.join("input_Cam038.png")).unwrap();
    let out = dir.path().join("out.pfm");
    assert_fails(
        &estimate(&full, &out, &["--align", "off"]),
        &["input_Cam038.png", "missing", "centre row and column"],
    );
    // Off the cross, read by the refinement only when its views reach there.
    let full = synth(dir.path(), "again", 32, &[]);
    std::fs::remove_file(full.join("input_Cam000.png")).unwrap();
    ok(&estimate(&full, &out, &["--align", "off"]));
}

#[test]
fn alignment_uses_the_views_that_exist() {
    let dir = common::temp();
    let full = synth(dir.path(), "misaligned", 96, &["--misalign"]);
    let cross = dir.path().join("cross");
    keep_views(&full, &cross, |r, c| r == 4 || c == 4);
    let out = dir.path().join("out.pfm");
    for align in ["on", "auto"] {
        let said = ok(&estimate(&cross, &out, &["--align", align]));
        assert!(said.contains("64 absent"), "{said}");
        // Every view of the cross, centre included, gets a homography.
        assert!(
            said.contains("alignment: 17 views aligned"),
            "{align}: {said}"
        );
    }
}
