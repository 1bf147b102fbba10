//! `--preset`: a named set of estimator parameters. `fast` must give exactly the map its
//! knobs give when spelled out, differ from `default`, and yield to explicit flags; an
//! unknown name must fail cleanly, listing the names; and on the shared HCI scenes (release
//! only) it must still beat SPO.

mod common;

use std::path::Path;

use common::lfdepth;

/// What `fast` sets, spelled out as the flags that set each knob.
const FAST_KNOBS: [&str; 6] = [
    "--sweep-color",
    "gray",
    "--refine-iterations",
    "1",
    "--median-passes",
    "3",
];

/// The default's values of the same knobs, read from `Params::default()` so that a
/// change of a default does not leave this test comparing against a stale value.
fn default_knobs() -> Vec<String> {
    let p = lfdepth::Params::default();
    let color = match p.sweep.color {
        lfdepth::planesweep::SweepColor::Rgb => "rgb",
        lfdepth::planesweep::SweepColor::Gray => "gray",
    };
    [
        ("--sweep-color", color.to_string()),
        ("--refine-iterations", p.refine.iterations.to_string()),
        ("--median-passes", p.median.passes.to_string()),
    ]
    .into_iter()
    .flat_map(|(flag, value)| [flag.to_string(), value])
    .collect()
}

/// The disparity map's bits `estimate` writes for `scene` with `extra` flags (one thread).
fn estimate(scene: &Path, out: &Path, extra: &[&str]) -> Vec<u32> {
    common::estimate_bits(scene, out, &[&["--threads", "1"][..], extra].concat())
}

#[test]
fn fast_preset_is_its_knobs_and_explicit_flags_override_it() {
    let dir = common::temp();
    let scene = common::synth_scene(&dir.path().join("mixed"), "mixed", 64, &[]);
    let out = dir.path().join("est.pfm");
    let default = estimate(&scene, &out, &[]);
    let named_default = estimate(&scene, &out, &["--preset", "default"]);
    let fast = estimate(&scene, &out, &["--preset", "fast"]);
    let spelled_out = estimate(&scene, &out, &FAST_KNOBS);
    let defaults = default_knobs();
    let mut overridden_args = vec!["--preset", "fast"];
    overridden_args.extend(defaults.iter().map(String::as_str));
    let overridden = estimate(&scene, &out, &overridden_args);

    assert_eq!(named_default, default, "--preset default is the default");
    assert_eq!(fast, spelled_out, "--preset fast sets exactly its knobs");
    let changed = fast.iter().zip(&default).filter(|(a, b)| a != b).count();
    assert!(changed > 0, "--preset fast left every pixel as the default");
    assert_eq!(
        overridden, default,
        "flags given with --preset fast override every knob it sets"
    );
}

#[test]
fn unknown_preset_names_fail_cleanly_listing_the_names() {
    let dir = common::temp();
    let out = dir.path().join("est.pfm");
    let dir_arg = dir.path().to_str().unwrap();
    let out_arg = out.to_str().unwrap();
    for args in [
        vec!["estimate", dir_arg, "-o", out_arg, "--preset", "quick"],
        vec!["eval", "--dataset", dir_arg, "--preset", "Fast"],
        vec!["demo", "--out", dir_arg, "--preset", ""],
    ] {
        let output = lfdepth(&args);
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert_eq!(output.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(
            stderr.contains("unknown preset") && stderr.contains("default, fast"),
            "{args:?}: {stderr}"
        );
    }
    assert!(!out.exists(), "nothing is written on a usage error");
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "512x512 scenes: run with cargo test --release"
)]
fn fast_preset_still_beats_spo_on_the_shared_hci_scenes() {
    // What the preset promises (Preset::Fast): below SPO on both scenes (measured
    // values in docs/BENCHMARKS.md, "Presets"; BadPix0.07 / MSE×100).
    common::assert_hci_below(
        "fast_preset_still_beats_spo_on_the_shared_hci_scenes",
        "--preset fast",
        &["--preset", "fast"],
        [
            ("stratified/backgammon", 2.55, 3.24),
            ("training/cotton", 2.59, 1.31),
        ],
    );
}
