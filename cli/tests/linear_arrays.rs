//! Linear arrays (one row or one column of cameras, a camera rail) through the binary:
//! `synth --grid 1x9` writes one with its ground truth, `estimate` reads it from the
//! one EPI direction it has and says that the other is absent, and the result scores
//! close to what a 2-D grid of the same scene gives. Rails of fewer than three views
//! are refused with the reason.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{assert_fails, lfdepth, lfdepth_json};

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The synthetic `mixed` scene of 128² on `grid` (e.g. `1x9`) in `dir/name`, with its
/// ground truth and `parameters.cfg`.
fn synth(dir: &Path, name: &str, grid: &str) -> PathBuf {
    common::synth_scene(&dir.join(name), "mixed", 128, &["--grid", grid])
}

fn estimate(input: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["estimate", s(input), "-o", s(out), "--threads", "2"];
    args.extend_from_slice(extra);
    lfdepth(&args)
}

fn ok(out: &Output) -> String {
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    stderr
}

/// BadPix0.07 (%) of `map` against the ground truth of `scene`.
fn badpix(map: &Path, scene: &Path) -> f64 {
    let gt = scene.join("gt_disp_lowres.pfm");
    let score = lfdepth_json(&["eval", s(map), "--gt", s(&gt), "--json"]);
    score["badpix007"].as_f64().expect("eval reports badpix007")
}

/// A 1×9 and a 9×1 rail of the `mixed` scene estimate from their one direction, say so,
/// and score BadPix0.07 below floors set at what they achieve plus about half a point:
/// from the plane sweep (the default) a row 5.38 %, a column 5.52 %, Q16.16 5.38 % and
/// 5.54 %, the sweep alone 8.5 % and 10.5 %; from the EPI start a row 5.41 %, a column
/// 6.42 %, Q16.16 5.43 % and 6.44 %, the EPI stage alone 18.2 % and 29.7 % (read as the
/// 3×3 grid its nine index-numbered views could also be, the row scores 7.9 % from the
/// EPI start with `--align off`).
#[test]
fn rails_estimate_from_their_one_direction() {
    let dir = common::temp();
    for (grid, floor, epi_floor, present, absent) in [
        ("1x9", 5.9, 6.0, "horizontal", "vertical"),
        ("9x1", 6.0, 7.0, "vertical", "horizontal"),
    ] {
        let scene = synth(dir.path(), grid, grid);
        let out = dir.path().join(format!("{grid}.pfm"));
        let run = estimate(&scene, &out, &[]);
        let said = ok(&run);
        assert!(
            said.contains(&format!("one direction ({present}) only"))
                && said.contains(&format!("the {absent} EPIs are absent")),
            "{said}"
        );
        // The default start is the plane sweep; from the EPI start the timings name the
        // one EPI step that ran.
        let timings = String::from_utf8_lossy(&run.stdout);
        assert!(
            timings.contains("sweep")
                && !timings.contains("epi horizontal")
                && !timings.contains("epi vertical"),
            "{timings}"
        );
        let f32_score = badpix(&out, &scene);
        assert!(
            f32_score < floor,
            "{grid}: BadPix0.07 {f32_score:.3} % not below {floor} %"
        );
        let epi_start = dir.path().join(format!("{grid}-epi-start.pfm"));
        let run = estimate(&scene, &epi_start, &["--initial", "epi"]);
        ok(&run);
        let timings = String::from_utf8_lossy(&run.stdout);
        assert!(timings.contains(&format!("epi {present}")), "{timings}");
        assert!(!timings.contains(&format!("epi {absent}")), "{timings}");
        let epi_start_score = badpix(&epi_start, &scene);
        assert!(
            epi_start_score < epi_floor,
            "{grid}: EPI start BadPix0.07 {epi_start_score:.3} % not below {epi_floor} %"
        );
        let q16 = dir.path().join(format!("{grid}-q16.pfm"));
        ok(&estimate(&scene, &q16, &["--scalar", "q16"]));
        let q16_score = badpix(&q16, &scene);
        assert!(
            q16_score < floor && (q16_score - f32_score).abs() < 0.5,
            "{grid}: Q16.16 BadPix0.07 {q16_score:.3} % (f32 {f32_score:.3} %)"
        );
        // Either start alone works on the one direction too; the later stages earn
        // their place.
        for (start, score) in [("sweep", f32_score), ("epi", epi_start_score)] {
            let epi = dir.path().join(format!("{grid}-{start}-alone.pfm"));
            ok(&estimate(
                &scene,
                &epi,
                &["--stage", "epi", "--initial", start],
            ));
            let alone = badpix(&epi, &scene);
            assert!(alone > score, "{grid}: {start} alone {alone:.3} %");
        }
    }
}

/// Copies the views of `scene` (`input_CamNNN.png`, k = 0..9) to `to` as `name(k)`,
/// without `parameters.cfg`: the grid must then come from the names or `--grid`.
fn copy_views(scene: &Path, to: &Path, name: impl Fn(usize) -> String) {
    std::fs::create_dir_all(to).unwrap();
    for k in 0..9 {
        let from = scene.join(format!("input_Cam{k:03}.png"));
        std::fs::copy(from, to.join(name(k))).unwrap();
    }
}

/// Names that tell a rail (`NAME_RR_CC` with one row or one column) give its grid;
/// nine views numbered by index stay a 3×3 grid with a note unless `--grid 1x9` says
/// otherwise, and then estimate as the rail with its `parameters.cfg` does, bit for
/// bit. A gapless run of index-numbered views that fills no square needs `--grid`.
#[test]
fn rail_names_give_the_grid_and_index_names_take_grid() {
    let dir = common::temp();
    let scene = synth(dir.path(), "scene", "1x9");
    let reference = dir.path().join("reference.pfm");
    ok(&estimate(&scene, &reference, &["-q"]));
    let reference = std::fs::read(&reference).unwrap();
    let out = dir.path().join("out.pfm");

    let row = dir.path().join("row");
    copy_views(&scene, &row, |k| format!("rail_00_{k:02}.png"));
    let said = ok(&estimate(&row, &out, &[]));
    assert!(said.contains("1x9 views") && said.contains("one direction (horizontal) only"));
    assert_eq!(std::fs::read(&out).unwrap(), reference, "row by its names");

    let indexed = dir.path().join("indexed");
    copy_views(&scene, &indexed, |k| format!("input_Cam{k:03}.png"));
    let said = ok(&estimate(&indexed, &out, &["--align", "off"]));
    assert!(
        said.contains("3x3 grid") && said.contains("--grid 1x9"),
        "{said}"
    );
    assert!(!said.contains("one direction"), "{said}");
    let said = ok(&estimate(&indexed, &out, &["--grid", "1x9"]));
    assert!(said.contains("one direction (horizontal) only"), "{said}");
    assert_eq!(std::fs::read(&out).unwrap(), reference, "--grid 1x9");

    // The same views as a column of cameras (they hold horizontal parallax, so the
    // estimate is poor, but it is read as the user said).
    let column = dir.path().join("column");
    copy_views(&scene, &column, |k| format!("rail_{k:02}_00.png"));
    let said = ok(&estimate(&column, &out, &["--stage", "epi"]));
    assert!(
        said.contains("9x1 views") && said.contains("one direction (vertical) only"),
        "{said}"
    );

    // Seven views numbered by index fill no square: the grid must be given.
    for k in 7..9 {
        std::fs::remove_file(indexed.join(format!("input_Cam{k:03}.png"))).unwrap();
    }
    assert_fails(
        &estimate(&indexed, &out, &[]),
        &["7 views numbered by index", "--grid 1x7", "--grid 7x1"],
    );
    ok(&estimate(&indexed, &out, &["--grid", "1x7"]));
}

/// One or two views in a row or column are no light field an EPI can use: a clear
/// error naming the count and the least that works, from the names, `--grid` and
/// `synth` alike.
#[test]
fn rails_of_fewer_than_three_views_are_refused() {
    let dir = common::temp();
    let scene = synth(dir.path(), "scene", "1x3");
    let out = dir.path().join("out.pfm");
    let two = dir.path().join("two");
    std::fs::create_dir_all(&two).unwrap();
    for k in 0..2 {
        std::fs::copy(
            scene.join(format!("input_Cam{k:03}.png")),
            two.join(format!("rail_00_{k:02}.png")),
        )
        .unwrap();
    }
    assert_fails(
        &estimate(&two, &out, &[]),
        &["one row of 2 cameras", "1x3", "3x3"],
    );
    std::fs::remove_file(two.join("rail_00_01.png")).unwrap();
    assert_fails(&estimate(&two, &out, &[]), &["holds one view", "1x3"]);
    assert_fails(
        &estimate(&scene, &out, &["--grid", "2x1"]),
        &["one column of 2 cameras", "3x1"],
    );
    assert!(!out.exists());
    let run = common::synth_command(&dir.path().join("short"), "mixed", &["--grid", "1x2"]);
    assert_fails(&run, &["1x2", "1x3"]);
}
