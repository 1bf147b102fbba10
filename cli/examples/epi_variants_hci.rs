//! The EPI stage alone on the HCI scenes of `../shared/data/hci` (backgammon, cotton)
//! with each variant of its parameters: the table of docs/stages/epi.md, one Markdown row
//! per variant and scene (BadPix0.07 % / BadPix0.03 % / MSE×100 / Q25, seconds per
//! estimate with all threads). Variant names as arguments run only those.
//!
//! ```text
//! cargo run --release -p lfdepth-cli --example epi_variants_hci [-- "VARIANT" …]
//! ```

#[path = "../tests/epi_support/mod.rs"]
mod epi_support;

use lfdepth::epi::{ColorMode, DisparityRange, EpiParams, Fusion, Search};

const SCENES: [&str; 2] = ["stratified/backgammon", "training/cotton"];

fn main() {
    let only: Vec<String> = std::env::args().skip(1).collect();
    let d = EpiParams::default();
    let variants: Vec<(&str, EpiParams)> = vec![
        ("paper (unsheared)", EpiParams::paper()),
        ("default", d),
        (
            "exhaustive search",
            EpiParams {
                search: Search::Exhaustive,
                ..d
            },
        ),
        (
            "coarse-to-fine, margin 0.5",
            EpiParams {
                search: Search::CoarseToFine { margin: 0.5 },
                ..d
            },
        ),
        (
            "step 1, exhaustive",
            EpiParams {
                shear_step: 1.0,
                search: Search::Exhaustive,
                ..d
            },
        ),
        (
            "gray, exhaustive",
            EpiParams {
                color: ColorMode::Gray,
                search: Search::Exhaustive,
                ..d
            },
        ),
        (
            "gray",
            EpiParams {
                color: ColorMode::Gray,
                ..d
            },
        ),
        (
            "weighted fusion",
            EpiParams {
                fusion: Fusion::Weighted,
                ..d
            },
        ),
        (
            "step 0.5",
            EpiParams {
                shear_step: 0.5,
                ..d
            },
        ),
        ("window 0.5", EpiParams { window: 0.5, ..d }),
        ("window 1.5", EpiParams { window: 1.5, ..d }),
        (
            "step 1",
            EpiParams {
                shear_step: 1.0,
                ..d
            },
        ),
        (
            "gray, step 1",
            EpiParams {
                color: ColorMode::Gray,
                shear_step: 1.0,
                ..d
            },
        ),
        (
            "A: outer 2, inner 0.5, step 0.5, weighted",
            EpiParams {
                outer_sigma: 2.0,
                inner_sigma: 0.5,
                shear_step: 0.5,
                fusion: Fusion::Weighted,
                ..d
            },
        ),
        (
            "B: outer 2, inner 0.5, weighted",
            EpiParams {
                outer_sigma: 2.0,
                inner_sigma: 0.5,
                fusion: Fusion::Weighted,
                ..d
            },
        ),
        (
            "C: outer 2, inner 0.5, step 0.5",
            EpiParams {
                outer_sigma: 2.0,
                inner_sigma: 0.5,
                shear_step: 0.5,
                ..d
            },
        ),
        (
            "D: outer 2, inner 0.5, step 0.5, window 0.75",
            EpiParams {
                outer_sigma: 2.0,
                inner_sigma: 0.5,
                shear_step: 0.5,
                window: 0.75,
                ..d
            },
        ),
        (
            "E: outer 1.75, inner 0.6, step 0.5, weighted",
            EpiParams {
                outer_sigma: 1.75,
                inner_sigma: 0.6,
                shear_step: 0.5,
                fusion: Fusion::Weighted,
                ..d
            },
        ),
        (
            "outer 1.0",
            EpiParams {
                outer_sigma: 1.0,
                ..d
            },
        ),
        (
            "outer 2.0",
            EpiParams {
                outer_sigma: 2.0,
                ..d
            },
        ),
        (
            "inner 0.5",
            EpiParams {
                inner_sigma: 0.5,
                ..d
            },
        ),
        (
            "inner 1.1",
            EpiParams {
                inner_sigma: 1.1,
                ..d
            },
        ),
        (
            "reference-like: range ±1.5, step 0.25, no interpolation",
            EpiParams {
                range: DisparityRange::Fixed {
                    min: -1.5,
                    max: 1.5,
                },
                shear_step: 0.25,
                interpolate: false,
                ..d
            },
        ),
        (
            "range ±1.5, step 0.25",
            EpiParams {
                range: DisparityRange::Fixed {
                    min: -1.5,
                    max: 1.5,
                },
                shear_step: 0.25,
                ..d
            },
        ),
        (
            "range ±1.6",
            EpiParams {
                range: DisparityRange::Fixed {
                    min: -1.6,
                    max: 1.6,
                },
                ..d
            },
        ),
        (
            "range ±1.6 step 0.5",
            EpiParams {
                range: DisparityRange::Fixed {
                    min: -1.6,
                    max: 1.6,
                },
                shear_step: 0.5,
                ..d
            },
        ),
        (
            "no interpolation",
            EpiParams {
                interpolate: false,
                ..d
            },
        ),
    ];
    if let Some(unknown) = only.iter().find(|o| !variants.iter().any(|(n, _)| n == o)) {
        eprintln!("error: no variant named `{unknown}`; the variants:");
        for (name, _) in &variants {
            eprintln!("  {name}");
        }
        std::process::exit(2);
    }
    println!("| variant | scene | BadPix0.07 % | BadPix0.03 % | MSE×100 | Q25 | s |");
    println!("|---|---|---:|---:|---:|---:|---:|");
    for (name, epi) in variants {
        if !only.is_empty() && !only.iter().any(|o| o == name) {
            continue;
        }
        for scene in SCENES {
            let Some((s, seconds)) =
                epi_support::epi_on_hci_scene("the EPI variants table", scene, epi)
            else {
                return;
            };
            println!(
                "| {name} | {scene} | {:.2} | {:.2} | {:.3} | {:.3} | {seconds:.2} |",
                s.badpix_007, s.badpix_003, s.mse100, s.q25
            );
        }
    }
}
