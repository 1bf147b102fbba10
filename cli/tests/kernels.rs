//! The AVX2 kernels the engine picks at run time give the same bits as the baseline
//! build's: every stage (EPI, refinement, refill, median, TV, and the warp of a
//! misaligned array), in `f32` and in Q16.16, with one and two threads.

use lfdepth::align::AlignMode;
use lfdepth::synth::{self, Misalignment, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography, LightField, Params};
use lfdepth_cli::engine::{
    avx2_available, estimate_with, Active, Estimate, EstimateOptions, Kernels, Precision,
    StageSelect,
};

fn size() -> usize {
    if cfg!(debug_assertions) {
        48
    } else {
        128
    }
}

fn render(kind: SceneKind, misalign: bool) -> (Vec<u8>, SynthSpec) {
    let n = size();
    let spec = SynthSpec {
        noise_sigma: 1.0,
        seed: 3,
        misalign: misalign.then_some(Misalignment {
            max_rotation_deg: 1.0,
            max_translation_px: 2.0,
            max_scale: 0.005,
            max_perspective: 0.001,
        }),
        ..SynthSpec::new(kind, Grid::new(9, 9), n, n)
    };
    let mut views = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; n * n];
    let mut homographies = vec![Homography::IDENTITY; 81];
    synth::render(&spec, &mut views, &mut gt, &mut homographies).unwrap();
    (views, spec)
}

fn run(
    views: &[u8],
    spec: &SynthSpec,
    params: Params,
    precision: Precision,
    threads: usize,
    kernels: Kernels,
) -> Estimate {
    let lf = LightField::new(views, spec.layout()).unwrap();
    let options = EstimateOptions {
        params,
        stage: StageSelect::Full,
        threads: Some(threads),
        kernels,
    };
    estimate_with(&lf, &options, precision, &mut |_, _, _| {}).unwrap()
}

fn bits(values: &[f32]) -> Vec<u32> {
    values.iter().map(|v| v.to_bits()).collect()
}

#[test]
fn avx2_kernels_give_the_baseline_bits() {
    if !avx2_available() {
        eprintln!(
            "NOTE: this CPU lacks AVX2 (or BMI/LZCNT/POPCNT/FMA): both runs take the \
             baseline kernels, so this test only checks that they agree"
        );
    }
    let rectified = render(SceneKind::Mixed, false);
    let misaligned = render(SceneKind::Planes, true);
    let mut aligned = Params::default();
    aligned.align.mode = AlignMode::On;
    let cases = [
        ("mixed, f32", &rectified, Params::default(), Precision::F32),
        ("mixed, Q16", &rectified, Params::default(), Precision::Q16),
        (
            "misaligned planes, align on",
            &misaligned,
            aligned,
            Precision::F32,
        ),
    ];
    for (name, (views, spec), params, precision) in cases {
        let baseline = run(views, spec, params, precision, 1, Kernels::Baseline);
        assert_eq!(baseline.kernels, Some(Active::Baseline));
        for threads in [1, 2] {
            let auto = run(views, spec, params, precision, threads, Kernels::Auto);
            let expected = if avx2_available() {
                Active::Avx2
            } else {
                Active::Baseline
            };
            assert_eq!(auto.kernels, Some(expected), "{name}");
            assert_eq!(
                bits(&auto.disparity),
                bits(&baseline.disparity),
                "{name}, {threads} threads: the disparity differs between the kernels"
            );
            assert_eq!(
                bits(&auto.confidence),
                bits(&baseline.confidence),
                "{name}, {threads} threads: the confidence differs between the kernels"
            );
            assert_eq!(
                bits(&auto.residuals),
                bits(&baseline.residuals),
                "{name}, {threads} threads: TV's residual history differs"
            );
        }
    }
}

/// The stage modules whose whole call tree must inline into the AVX2 entry.
const HOT_MODULES: [&str; 6] = [
    "epi",
    "refine",
    "median",
    "tv",
    "geofill.rs",
    "align/warp.rs",
];

/// Functions (outside test modules) of `source` that lack `inline(always)` on x86-64:
/// those would run as baseline code inside the AVX2 path. Trait method declarations
/// and `#[inline(never)]` functions (kept out of line on purpose) are not counted.
fn not_inlined(source: &str) -> Vec<String> {
    let lines: Vec<&str> = source.lines().collect();
    let mut missing = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        let code = line.trim_start();
        if code.starts_with("#[cfg(test)]")
            && lines
                .get(i + 1)
                .is_some_and(|next| next.trim_start().starts_with("mod "))
        {
            break;
        }
        let signature = code
            .trim_start_matches("pub ")
            .trim_start_matches("pub(crate) ")
            .trim_start_matches("pub(super) ")
            .trim_start_matches("const ");
        if !signature.starts_with("fn ") || code.starts_with("const fn") {
            continue;
        }
        // A declaration without a body (a trait's required method) ends in ';'.
        let end = lines[i..]
            .iter()
            .map(|l| l.split("//").next().unwrap_or("").trim_end())
            .find(|l| l.contains('{') || l.ends_with(';'))
            .unwrap_or("");
        if !end.contains('{') {
            continue;
        }
        let attributes: Vec<&str> = lines[..i]
            .iter()
            .rev()
            .map(|l| l.trim())
            .take_while(|l| l.starts_with("#[") || l.starts_with("///"))
            .collect();
        let inlined = attributes.iter().any(|a| {
            *a == "#[inline(always)]"
                || *a == "#[inline(never)]"
                || a.contains("x86_64\", inline(always))")
        });
        if !inlined {
            missing.push(format!("line {}: {}", i + 1, code));
        }
    }
    missing
}

#[test]
fn every_stage_function_inlines_into_the_avx2_entry() {
    let core = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../core/src");
    let mut files = Vec::new();
    for module in HOT_MODULES {
        let path = core.join(module);
        if path.is_dir() {
            for entry in std::fs::read_dir(&path).unwrap() {
                files.push(entry.unwrap().path());
            }
        } else {
            files.push(path);
        }
    }
    files.sort();
    let mut missing = Vec::new();
    for file in files {
        let name = file.file_name().unwrap().to_string_lossy().to_string();
        if name.contains("test") {
            continue;
        }
        let source = std::fs::read_to_string(&file).unwrap();
        for m in not_inlined(&source) {
            missing.push(format!("{}: {m}", file.display()));
        }
    }
    assert!(
        missing.is_empty(),
        "add #[cfg_attr(target_arch = \"x86_64\", inline(always))] to these functions (see \
         core/src/lib.rs), or they run as baseline code in the AVX2 path:\n{}",
        missing.join("\n")
    );
}

#[test]
fn the_inlining_check_finds_a_plain_function() {
    let source = "/// doc\n#[cfg_attr(target_arch = \"x86_64\", inline(always))]\nfn a() {}\n\
                  fn b(x: u32)\n    -> u32 {\n    x\n}\ntrait T {\n    fn c(&self);\n}\n\
                  #[inline(never)]\nfn d() {}\n#[cfg(test)]\nmod tests {\n    fn e() {}\n}\n";
    assert_eq!(
        not_inlined(source),
        vec!["line 4: fn b(x: u32)".to_string()]
    );
}
