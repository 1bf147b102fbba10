//! [`TUNABLES`]: every user-facing parameter, its names, documentation, kind and the
//! fields of [`Params`] it reads and writes.

use super::{Flag, Kind, Tunable, Value};
use crate::align::{AlignMode, AlignedViews, Interpolation};
use crate::epi::{ColorMode, EpiParams, Fusion};
use crate::planesweep::SweepColor;

fn float(v: Value) -> Option<f32> {
    match v {
        Value::Float(x) => Some(x),
        _ => None,
    }
}

fn int(v: Value) -> Option<usize> {
    match v {
        Value::Int(x) => Some(x),
        _ => None,
    }
}

fn boolean(v: Value) -> Option<bool> {
    match v {
        Value::Bool(x) => Some(x),
        _ => None,
    }
}

fn choice(v: Value) -> Option<&'static str> {
    match v {
        Value::Choice(x) => Some(x),
        _ => None,
    }
}

const fn closed(min: f32, max: f32) -> Kind {
    Kind::Float {
        min,
        max,
        min_open: false,
    }
}

const fn ints(min: usize, max: usize) -> Kind {
    Kind::Int { min, max }
}

const ALIGN_MODES: &[&str] = &["off", "on", "auto"];
const INTERPOLATIONS: &[&str] = &["bilinear", "sharpened-bilinear", "catmull-rom"];
const ALIGNED_VIEWS: &[&str] = &["read", "cross", "all"];
const FUSIONS: &[&str] = &["coherence", "weighted"];
const COLORS: &[&str] = &["tensor", "gray"];
const INITIALS: &[&str] = &["epi", "sweep", "fused"];
const SWEEP_COLORS: &[&str] = &["rgb", "gray"];

/// Every tunable, in the order the front ends apply them (a later one may build on an
/// earlier one: `--no-shear` replaces the whole EPI stage's settings, so it comes first
/// among them).
pub static TUNABLES: &[Tunable] = &[
    // Alignment.
    Tunable {
        flag: Some(Flag::Value("--align")),
        key: Some("align"),
        doc: "Align the views by per-view homographies first: off, on (fails on views that cannot be aligned), or auto (only when the array is found not to be rectified; warns and goes on unaligned when it cannot be aligned)",
        kind: Kind::Choice(ALIGN_MODES),
        path: "align.mode",
        get: |p| {
            Value::Choice(match p.align.mode {
                AlignMode::Off => "off",
                AlignMode::On => "on",
                AlignMode::Auto => "auto",
            })
        },
        set: |p, v| {
            p.align.mode = match choice(v)? {
                "off" => AlignMode::Off,
                "on" => AlignMode::On,
                "auto" => AlignMode::Auto,
                _ => return None,
            };
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--align-interp")),
        key: Some("alignInterp"),
        doc: "Alignment: how the views are resampled into the rectified array: bilinear (fastest, blurs fine texture), sharpened-bilinear (bilinear plus a 3-tap sharpening, as sharp as Catmull–Rom on alignment's maps) or catmull-rom (4×4 cubic taps, about 1.4× sharpened-bilinear's warp time)",
        kind: Kind::Choice(INTERPOLATIONS),
        path: "align.interpolation",
        get: |p| {
            Value::Choice(match p.align.interpolation {
                Interpolation::Bilinear => "bilinear",
                Interpolation::SharpenedBilinear => "sharpened-bilinear",
                Interpolation::CatmullRom => "catmull-rom",
            })
        },
        set: |p, v| {
            p.align.interpolation = match choice(v)? {
                "bilinear" => Interpolation::Bilinear,
                "sharpened-bilinear" => Interpolation::SharpenedBilinear,
                "catmull-rom" => Interpolation::CatmullRom,
                _ => return None,
            };
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--align-views")),
        key: Some("alignViews"),
        doc: "Alignment: which views get a homography: read (those the stages read), cross (the centre row and column) or all (every view: a smaller disparity offset no image can observe, slower)",
        kind: Kind::Choice(ALIGNED_VIEWS),
        path: "align.views",
        get: |p| {
            Value::Choice(match p.align.views {
                AlignedViews::Read => "read",
                AlignedViews::Cross => "cross",
                AlignedViews::All => "all",
            })
        },
        set: |p, v| {
            p.align.views = match choice(v)? {
                "read" => AlignedViews::Read,
                "cross" => AlignedViews::Cross,
                "all" => AlignedViews::All,
                _ => return None,
            };
            Some(())
        },
    },
    // EPI stage.
    Tunable {
        flag: Some(Flag::Switch {
            name: "--no-shear",
            sets: true,
            doc: "The paper's EPI variant: one unsheared EPI per direction (with its scales 0.8 and 1.5 and the widest fixed range) instead of shear hypotheses over the range",
        }),
        key: None,
        doc: "The paper's EPI variant instead of shear hypotheses (true replaces every EPI setting by the paper's; false restores the defaults when they were the paper's)",
        kind: Kind::Bool,
        path: "epi.paper",
        get: |p| Value::Bool(!p.epi.shear),
        set: |p, v| {
            if boolean(v)? {
                p.epi = EpiParams::paper();
            } else if !p.epi.shear {
                p.epi = EpiParams::default();
            }
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-inner-sigma")),
        key: Some("innerSigma"),
        doc: "EPI stage: Gaussian pre-smoothing along the EPI line (px)",
        kind: closed(0.0, 4.0),
        path: "inner_sigma",
        get: |p| Value::Float(p.epi.inner_sigma),
        set: |p, v| {
            p.epi.inner_sigma = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-outer-sigma")),
        key: Some("outerSigma"),
        doc: "EPI stage: Gaussian smoothing of the structure tensor along the line and across views (px)",
        kind: closed(0.0, 5.0),
        path: "outer_sigma",
        get: |p| Value::Float(p.epi.outer_sigma),
        set: |p, v| {
            p.epi.outer_sigma = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: None,
        key: Some("shear"),
        doc: "EPI stage: shear the EPIs over the range (false: one unsheared EPI per direction, the other settings kept)",
        kind: Kind::Bool,
        path: "shear",
        get: |p| Value::Bool(p.epi.shear),
        set: |p, v| {
            p.epi.shear = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-shear-step")),
        key: Some("shearStep"),
        doc: "EPI stage: distance between shear hypotheses in px (larger: fewer hypotheses, faster, coarser)",
        kind: closed(0.1, 2.0),
        path: "shear_step",
        get: |p| Value::Float(p.epi.shear_step),
        set: |p, v| {
            p.epi.shear_step = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-window")),
        key: Some("window"),
        doc: "EPI stage: largest residual slope a hypothesis accepts, in shear steps",
        kind: closed(0.5, 2.0),
        path: "window",
        get: |p| Value::Float(p.epi.window),
        set: |p, v| {
            p.epi.window = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-interpolate")),
        key: Some("interpolate"),
        doc: "EPI stage: interpolate between adjacent shears at the zero crossing of the residual slope (off: the single most coherent hypothesis)",
        kind: Kind::Bool,
        path: "interpolate",
        get: |p| Value::Bool(p.epi.interpolate),
        set: |p, v| {
            p.epi.interpolate = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-half")),
        key: Some("epiHalf"),
        doc: "EPI stage: estimate on views box-filtered 2× (a quarter of the samples, half the shears), then upsample the map guided by the centre view's colour",
        kind: Kind::Bool,
        path: "half_resolution",
        get: |p| Value::Bool(p.epi.half_resolution),
        set: |p, v| {
            p.epi.half_resolution = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-fusion")),
        key: Some("fusion"),
        doc: "EPI stage: how the horizontal and vertical estimates are combined: coherence (the more confident one) or weighted (their confidence-weighted mean where they agree within 0.1 px)",
        kind: Kind::Choice(FUSIONS),
        path: "fusion",
        get: |p| {
            Value::Choice(match p.epi.fusion {
                Fusion::Coherence => "coherence",
                Fusion::Weighted => "weighted",
            })
        },
        set: |p, v| {
            p.epi.fusion = match choice(v)? {
                "coherence" => Fusion::Coherence,
                "weighted" => Fusion::Weighted,
                _ => return None,
            };
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-color")),
        key: Some("color"),
        doc: "EPI stage: tensor (one structure tensor over R, G, B) or gray (the channels' mean first, a third of the tensor work)",
        kind: Kind::Choice(COLORS),
        path: "color",
        get: |p| {
            Value::Choice(match p.epi.color {
                ColorMode::Tensor => "tensor",
                ColorMode::Gray => "gray",
            })
        },
        set: |p, v| {
            p.epi.color = match choice(v)? {
                "tensor" => ColorMode::Tensor,
                "gray" => ColorMode::Gray,
                _ => return None,
            };
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-chroma")),
        key: Some("epiChroma"),
        doc: "EPI stage, tensor colour: weight of each channel's difference from the channels' mean (in pixels paler than --epi-chroma-knee when that is set; 1: the plain R, G, B tensor; 0: the channels' mean only, the least noise)",
        kind: closed(0.0, 1.0),
        path: "chroma",
        get: |p| Value::Float(p.epi.chroma),
        set: |p, v| {
            p.epi.chroma = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--epi-chroma-knee")),
        key: Some("epiChromaKnee"),
        doc: "EPI stage, tensor colour: saturation (colour relative to brightness) above which a pixel keeps its channels' differences whole; paler colour is scaled by --epi-chroma (0: every pixel scaled)",
        kind: closed(0.0, 1.0),
        path: "chroma_knee",
        get: |p| Value::Float(p.epi.chroma_knee),
        set: |p, v| {
            p.epi.chroma_knee = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--disparity-range")),
        key: Some("range"),
        doc: "Disparity search range in px between adjacent views: auto (estimated from the views) or fixed from a minimum to a maximum",
        kind: Kind::Range,
        path: "disparity range",
        get: |p| Value::Range(p.epi.range),
        set: |p, v| match v {
            Value::Range(range) => {
                p.epi.range = range;
                Some(())
            }
            _ => None,
        },
    },
    // Plane sweep.
    Tunable {
        flag: Some(Flag::Value("--initial")),
        key: Some("initial"),
        doc: "Initial disparity: epi (the structure tensor on sheared EPIs), sweep (a plane sweep over the EPI stage's range with window-aggregated truncated differences to the centre row and column of views) or fused (both, each refined, per pixel the one with the lower photometric cost over a 3×3 window)",
        kind: Kind::Choice(INITIALS),
        path: "initial",
        get: |p| {
            Value::Choice(if p.fused {
                "fused"
            } else if p.sweep.enabled {
                "sweep"
            } else {
                "epi"
            })
        },
        set: |p, v| {
            (p.sweep.enabled, p.fused) = match choice(v)? {
                "epi" => (false, false),
                "sweep" => (true, false),
                "fused" => (true, true),
                _ => return None,
            };
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--sweep-step")),
        key: Some("sweepStep"),
        doc: "Plane sweep: largest distance between hypotheses (px)",
        kind: closed(0.05, 1.0),
        path: "sweep.step",
        get: |p| Value::Float(p.sweep.step),
        set: |p, v| {
            p.sweep.step = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--sweep-radius")),
        key: Some("sweepRadius"),
        doc: "Plane sweep: radius (px) of the square window the matching costs are summed over",
        kind: ints(0, crate::planesweep::MAX_RADIUS),
        path: "sweep.radius",
        get: |p| Value::Int(p.sweep.radius),
        set: |p, v| {
            p.sweep.radius = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--sweep-truncate")),
        key: Some("sweepTruncate"),
        doc: "Plane sweep: each channel's absolute difference to the centre view counts at most this much (unit intensity)",
        kind: closed(0.001, 1.0),
        path: "sweep.truncate",
        get: |p| Value::Float(p.sweep.truncate),
        set: |p, v| {
            p.sweep.truncate = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--sweep-select")),
        key: Some("sweepSelect"),
        doc: "Plane sweep: a one-axis volume's winner replaces the combined one's when its confidence exceeds the combined one's times this",
        kind: closed(1.0, 4.0),
        path: "sweep.select",
        get: |p| Value::Float(p.sweep.select),
        set: |p, v| {
            p.sweep.select = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--sweep-line")),
        key: Some("sweepLine"),
        doc: "Plane sweep: the one-axis volumes' windows are lines this many times the radius long on each side",
        kind: ints(1, crate::planesweep::MAX_LINE),
        path: "sweep.line",
        get: |p| Value::Int(p.sweep.line),
        set: |p, v| {
            p.sweep.line = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--sweep-trust")),
        key: Some("sweepTrust"),
        doc: "Plane sweep: below this sweep confidence the refined confidence is scaled by the square of the sweep's over this, so TV weighs such starts less (0: off)",
        kind: closed(0.0, 1.0),
        path: "sweep.trust",
        get: |p| Value::Float(p.sweep.trust),
        set: |p, v| {
            p.sweep.trust = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--sweep-candidate")),
        key: Some("sweepCandidate"),
        doc: "Plane sweep: side (px, odd) of a small square window whose confident winner per pixel the refinement's first propagation round tries as one more candidate where two opposite neighbours' winners agree with it, for structures narrower than the sweep's windows (1: the pixel alone; 0: off)",
        kind: ints(0, crate::planesweep::MAX_CANDIDATE),
        path: "sweep.candidate",
        get: |p| Value::Int(p.sweep.candidate),
        set: |p, v| {
            p.sweep.candidate = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--sweep-color")),
        key: Some("sweepColor"),
        doc: "Plane sweep: match each view on rgb (each colour channel's truncated difference) or gray (the channels' mean, converted once per band: a third of the matching's work)",
        kind: Kind::Choice(SWEEP_COLORS),
        path: "sweep.color",
        get: |p| {
            Value::Choice(match p.sweep.color {
                SweepColor::Rgb => "rgb",
                SweepColor::Gray => "gray",
            })
        },
        set: |p, v| {
            p.sweep.color = match choice(v)? {
                "rgb" => SweepColor::Rgb,
                "gray" => SweepColor::Gray,
                _ => return None,
            };
            Some(())
        },
    },
    // Photometric refinement.
    Tunable {
        flag: Some(Flag::Value("--refine")),
        key: Some("refine"),
        doc: "Photometric refinement of the EPI disparity over many views",
        kind: Kind::Bool,
        path: "refine.enabled",
        get: |p| Value::Bool(p.refine.enabled),
        set: |p, v| {
            p.refine.enabled = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-iterations")),
        key: Some("refineIterations"),
        doc: "Refinement: Gauss–Newton iterations",
        kind: ints(1, 16),
        path: "refine.iterations",
        get: |p| Value::Int(p.refine.iterations),
        set: |p, v| {
            p.refine.iterations = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-propagation")),
        key: Some("refinePropagation"),
        doc: "Refinement: rounds of propagation before the iterations (jumps of 8, 4, 2, 1 px, the last N of them)",
        kind: ints(0, 4),
        path: "refine.propagation",
        get: |p| Value::Int(p.refine.propagation),
        set: |p, v| {
            p.refine.propagation = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-radius")),
        key: Some("refineRadius"),
        doc: "Refinement: radius of the aggregation window (px)",
        kind: ints(0, 4),
        path: "refine.radius",
        get: |p| Value::Int(p.refine.radius),
        set: |p, v| {
            p.refine.radius = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-slack")),
        key: Some("refineSlack"),
        doc: "Refinement: sampling slack in px of image motion: a view's residual counts only by how far it falls outside the centre view's values over ±F px (0: the plain residual; on warped views the pipeline uses 0.5 when this is 0)",
        kind: closed(0.0, 1.0),
        path: "refine.sampling_slack",
        get: |p| Value::Float(p.refine.sampling_slack),
        set: |p, v| {
            p.refine.sampling_slack = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-skip-settled")),
        key: Some("refineSkipSettled"),
        doc: "Refinement: after the first Gauss–Newton iteration, a pixel that kept its statistics and whose window's other pixels each moved by less than F px keeps its disparity and confidence (0: update every pixel in every iteration)",
        kind: closed(0.0, 1.0),
        path: "refine.skip_settled",
        get: |p| Value::Float(p.refine.skip_settled),
        set: |p, v| {
            p.refine.skip_settled = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-slant")),
        key: Some("refineSlant"),
        doc: "Refinement: slanted window: neighbours' Gauss–Newton statistics are moved along the local slope of the disparity and gated by their distance from that plane (0: the fronto-parallel window)",
        kind: Kind::Bool,
        path: "refine.slanted",
        get: |p| Value::Bool(p.refine.slanted),
        set: |p, v| {
            p.refine.slanted = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--refine-band-rows")),
        key: Some("refineBandRows"),
        doc: "Refinement: image rows per band, one part of the refinement step",
        kind: ints(1, 4096),
        path: "refine.band_rows",
        get: |p| Value::Int(p.refine.band_rows),
        set: |p, v| {
            p.refine.band_rows = int(v)?;
            Some(())
        },
    },
    // Geodesic refill.
    Tunable {
        flag: Some(Flag::Value("--fill")),
        key: Some("geofill"),
        doc: "Geodesic refill of the band around depth steps (after the refinement, before the median): each pixel near a step takes the value of the outside pixel it reaches through the most uniform colour, so a foreground fattened into a flat background returns to its colour edge",
        kind: Kind::Bool,
        path: "geofill.enabled",
        get: |p| Value::Bool(p.geofill.enabled),
        set: |p, v| {
            p.geofill.enabled = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--fill-band")),
        key: Some("fillBand"),
        doc: "Geodesic refill: width (px, city-block) of the band refilled around each step (the seeds' reach grows to twice it when needed)",
        kind: ints(1, 32),
        path: "geofill.band",
        get: |p| Value::Int(p.geofill.band),
        set: |p, v| {
            let band = int(v)?;
            p.geofill.band = band;
            p.geofill.reach = p.geofill.reach.max(band.saturating_mul(2));
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--fill-step")),
        key: Some("fillStep"),
        doc: "Geodesic refill: a disparity difference between 4-neighbours larger than this (px) is a depth step",
        kind: closed(0.01, 16.0),
        path: "geofill.step",
        get: |p| Value::Float(p.geofill.step),
        set: |p, v| {
            p.geofill.step = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--fill-edge")),
        key: Some("fillEdge"),
        doc: "Geodesic refill: a depth step with a colour step (largest channel difference, unit intensity) of at least this within 2 px across it sits on its colour edge and is left alone",
        kind: closed(0.001, 1.0),
        path: "geofill.edge",
        get: |p| Value::Float(p.geofill.edge),
        set: |p, v| {
            p.geofill.edge = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--fill-max-cost")),
        key: Some("fillMaxCost"),
        doc: "Geodesic refill: a band pixel whose cheapest colour path to a pixel outside the band costs more than this (unit intensity) keeps its value",
        kind: closed(0.001, 16.0),
        path: "geofill.max_cost",
        get: |p| Value::Float(p.geofill.max_cost),
        set: |p, v| {
            p.geofill.max_cost = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--fill-spatial")),
        key: Some("fillSpatial"),
        doc: "Geodesic refill: path cost per pixel of length, in unit intensity, against the colour differences crossed",
        kind: closed(0.0001, 1.0),
        path: "geofill.spatial",
        get: |p| Value::Float(p.geofill.spatial),
        set: |p, v| {
            p.geofill.spatial = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Switch {
            name: "--fill-planar",
            sets: true,
            doc: "Geodesic refill: extrapolate the source pixel's value along its slope instead of copying it",
        }),
        key: Some("fillPlanar"),
        doc: "Geodesic refill: extrapolate the source pixel's value along its slope instead of copying it",
        kind: Kind::Bool,
        path: "geofill.planar",
        get: |p| Value::Bool(p.geofill.planar),
        set: |p, v| {
            p.geofill.planar = boolean(v)?;
            Some(())
        },
    },
    // Weighted median.
    Tunable {
        flag: None,
        key: Some("median"),
        doc: "Edge-snapping weighted median guided by the centre view",
        kind: Kind::Bool,
        path: "median.enabled",
        get: |p| Value::Bool(p.median.enabled),
        set: |p, v| {
            p.median.enabled = boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--median")),
        key: Some("medianRadius"),
        doc: "Edge-snapping weighted median guided by the centre view: window radius in px, or 0 to switch it off",
        kind: ints(0, 7),
        path: "median.radius",
        get: |p| Value::Int(if p.median.enabled { p.median.radius } else { 0 }),
        set: |p, v| {
            match int(v)? {
                0 => p.median.enabled = false,
                radius => p.median.radius = radius,
            }
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--median-sigma")),
        key: Some("medianSigma"),
        doc: "Weighted median: colour scale σ of the weights (unit intensity)",
        kind: closed(0.005, 0.5),
        path: "median.color_sigma",
        get: |p| Value::Float(p.median.color_sigma),
        set: |p, v| {
            p.median.color_sigma = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--median-passes")),
        key: Some("medianPasses"),
        doc: "Weighted median: passes (each moves a fattened band a window further back onto its colour edge)",
        kind: ints(1, 4),
        path: "median.passes",
        get: |p| Value::Int(p.median.passes),
        set: |p, v| {
            p.median.passes = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--median-gate")),
        key: Some("medianGate"),
        doc: "Weighted median: only pixels whose window holds a step between adjacent pixels larger than this (px) are filtered",
        kind: closed(0.0, 16.0),
        path: "median.gate",
        get: |p| Value::Float(p.median.gate),
        set: |p, v| {
            p.median.gate = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--median-snap")),
        key: Some("medianSnap"),
        doc: "Weighted median: a pixel takes the median only when it differs from it by more than this (px)",
        kind: closed(0.0, 16.0),
        path: "median.snap",
        get: |p| Value::Float(p.median.snap),
        set: |p, v| {
            p.median.snap = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--median-thin")),
        key: Some("medianThin"),
        doc: "Weighted median: a pixel keeps its value when the pixels of its value joined to it cross its window with a mean width of at most this (px): thin structures survive; 0 switches the test off",
        kind: closed(0.0, 16.0),
        path: "median.thin",
        get: |p| Value::Float(p.median.thin),
        set: |p, v| {
            p.median.thin = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Switch {
            name: "--median-flat",
            sets: true,
            doc: "Weighted median: neighbours vote with their own value instead of extrapolating along the local slope (best on scenes of flat surfaces)",
        }),
        key: Some("medianFlat"),
        doc: "Weighted median: neighbours vote with their own value instead of extrapolating along the local slope",
        kind: Kind::Bool,
        path: "median.flat",
        get: |p| Value::Bool(!p.median.planar),
        set: |p, v| {
            p.median.planar = !boolean(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Switch {
            name: "--median-after-tv",
            sets: false,
            doc: "Weighted median: run it after TV instead of between the refinement and TV",
        }),
        key: Some("medianBeforeTv"),
        doc: "Weighted median: run it between the refinement and TV (true) or after TV (false)",
        kind: Kind::Bool,
        path: "median.before_tv",
        get: |p| Value::Bool(p.median.before_tv),
        set: |p, v| {
            p.median.before_tv = boolean(v)?;
            Some(())
        },
    },
    // Total-variation refinement.
    Tunable {
        flag: Some(Flag::Value("--lambda")),
        key: Some("lambda"),
        doc: "TV refinement: weight λ of the total variation against the data term (larger: smoother)",
        kind: Kind::Float {
            min: 0.0,
            max: 1000.0,
            min_open: true,
        },
        path: "tv.lambda",
        get: |p| Value::Float(p.tv.lambda),
        set: |p, v| {
            p.tv.lambda = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--tv-iterations")),
        key: Some("iterations"),
        doc: "TV refinement: most PPXA iterations per tile",
        kind: ints(1, 100_000),
        path: "tv.max_iterations",
        get: |p| Value::Int(p.tv.max_iterations),
        set: |p, v| {
            p.tv.max_iterations = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--tv-tolerance")),
        key: Some("tvTolerance"),
        doc: "TV refinement: stopping tolerance, the RMS change of the refined disparity over one iteration in px (0: run every iteration; smaller: closer to the exact minimiser)",
        kind: closed(0.0, f32::INFINITY),
        path: "tv.tolerance",
        get: |p| Value::Float(p.tv.tolerance),
        set: |p, v| {
            p.tv.tolerance = float(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--tv-tile")),
        key: Some("tvTile"),
        doc: "TV refinement: side of a tile's core in px (one part of each TV step)",
        kind: ints(8, 4096),
        path: "tv.tile",
        get: |p| Value::Int(p.tv.tile),
        set: |p, v| {
            p.tv.tile = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--tv-halo")),
        key: Some("tvHalo"),
        doc: "TV refinement: pixels of context around each tile",
        kind: ints(0, 256),
        path: "tv.halo",
        get: |p| Value::Int(p.tv.halo),
        set: |p, v| {
            p.tv.halo = int(v)?;
            Some(())
        },
    },
    Tunable {
        flag: Some(Flag::Value("--tv-sweeps")),
        key: Some("tvSweeps"),
        doc: "TV refinement: outer sweeps: solve every tile again from the previous pass's dual with the flows across its border held at the neighbours' values, so tiles agree where they meet",
        kind: ints(0, 8),
        path: "tv.sweeps",
        get: |p| Value::Int(p.tv.sweeps),
        set: |p, v| {
            p.tv.sweeps = int(v)?;
            Some(())
        },
    },
];
