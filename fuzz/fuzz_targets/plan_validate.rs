//! Arbitrary layout numbers and EPI parameters through `Plan::new` (and the EPI scratch
//! sizes of a valid plan); when the plan is valid
//! and small, a `LightField` over a buffer of the claimed size (and one element short),
//! probed with arbitrary indices. Every accessor must agree with an independent index
//! computation: `Some(sample)` inside the light field, `None`/`Err` outside, no panic.
#![no_main]

use lfdepth::epi::{self, ColorMode, Direction, DisparityRange, EpiParams, Fusion, Search};
use lfdepth::{Grid, Layout, LightField, Params, Plan};
use libfuzzer_sys::arbitrary::{self, Arbitrary};
use libfuzzer_sys::fuzz_target;

/// A size or index: mostly small (where valid layouts live), sometimes anything.
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Number {
    Small(u8),
    Medium(u16),
    Any(usize),
}

impl Number {
    fn get(self) -> usize {
        match self {
            Number::Small(n) => n as usize,
            Number::Medium(n) => n as usize,
            Number::Any(n) => n,
        }
    }
}

/// A parameter value: mostly on a grid of sixteenths in −8…8 (where the valid ranges
/// are), sometimes any bit pattern (NaN, infinities, subnormals).
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Real {
    Sixteenths(i8),
    Any(f32),
}

impl Real {
    fn get(self) -> f32 {
        match self {
            Real::Sixteenths(n) => n as f32 / 16.0,
            Real::Any(x) => x,
        }
    }
}

/// Every field of `EpiParams`.
#[derive(Arbitrary, Debug)]
struct EpiInput {
    inner_sigma: Real,
    outer_sigma: Real,
    fixed_range: Option<(Real, Real)>,
    shear: bool,
    shear_step: Real,
    window: Real,
    interpolate: bool,
    weighted_fusion: bool,
    gray: bool,
    chroma: Real,
    chroma_knee: Real,
    /// `None`: the exhaustive search; `Some(margin)`: coarse-to-fine.
    coarse_margin: Option<Real>,
    half_resolution: bool,
}

impl EpiInput {
    fn params(&self) -> EpiParams {
        EpiParams {
            inner_sigma: self.inner_sigma.get(),
            outer_sigma: self.outer_sigma.get(),
            range: match self.fixed_range {
                None => DisparityRange::Auto,
                Some((min, max)) => DisparityRange::Fixed {
                    min: min.get(),
                    max: max.get(),
                },
            },
            shear: self.shear,
            shear_step: self.shear_step.get(),
            window: self.window.get(),
            interpolate: self.interpolate,
            fusion: if self.weighted_fusion {
                Fusion::Weighted
            } else {
                Fusion::Coherence
            },
            color: if self.gray {
                ColorMode::Gray
            } else {
                ColorMode::Tensor
            },
            chroma: self.chroma.get(),
            chroma_knee: self.chroma_knee.get(),
            search: match self.coarse_margin {
                None => Search::Exhaustive,
                Some(margin) => Search::CoarseToFine {
                    margin: margin.get(),
                },
            },
            half_resolution: self.half_resolution,
        }
    }
}

#[derive(Arbitrary, Debug)]
struct Input {
    rows: Number,
    cols: Number,
    width: Number,
    height: Number,
    channels: Number,
    /// Strides as packed plus padding, or as raw numbers.
    strides: Strides,
    epi: EpiInput,
    probes: Vec<Probe>,
}

#[derive(Arbitrary, Debug)]
enum Strides {
    Padded { row_pad: Number, view_pad: Number },
    Raw { row: Number, view: Number },
}

/// One accessor call with arbitrary indices.
#[derive(Arbitrary, Debug)]
struct Probe {
    row: Number,
    col: Number,
    x: Number,
    y: Number,
    channel: Number,
}

/// Buffers above this many samples are not allocated (the plan is still validated).
const MAX_SAMPLES: usize = 1 << 18;

fuzz_target!(|input: Input| {
    let grid = Grid::new(input.rows.get(), input.cols.get());
    let (width, height, channels) = (input.width.get(), input.height.get(), input.channels.get());
    let mut layout = Layout::packed(grid, width, height, channels);
    match input.strides {
        Strides::Padded { row_pad, view_pad } => {
            layout.row_stride = layout.row_stride.saturating_add(row_pad.get());
            let view = layout.row_stride.saturating_mul(height);
            layout.view_stride = view.saturating_add(view_pad.get());
        }
        Strides::Raw { row, view } => {
            layout.row_stride = row.get();
            layout.view_stride = view.get();
        }
    }
    // Only the EPI parameters are fuzzed, from the EPI start; the other stages take their
    // defaults.
    let params = Params {
        epi: input.epi.params(),
        sweep: lfdepth::planesweep::PlaneSweepParams::off(),
        ..Params::default()
    };

    let validated = layout.validate();
    let epi_valid = params.epi.validate();
    let plan = Plan::new(layout, params);
    assert_eq!(
        plan.is_ok(),
        validated.is_ok() && epi_valid.is_ok(),
        "Plan::new disagrees with Layout::validate and EpiParams::validate"
    );
    let (Ok(plan), Ok(needed)) = (plan, validated) else {
        return;
    };
    assert_eq!(plan.pixels(), width * height);
    // Scratch sizes of a valid plan are computed without panicking (checked arithmetic).
    let _ = epi::scratch_len(plan.epi());
    for direction in [Direction::Horizontal, Direction::Vertical] {
        let _ = epi::band_scratch_len(plan.epi(), direction);
    }
    assert!(needed >= grid.len() * width * height * channels);
    if needed > MAX_SAMPLES {
        return;
    }

    let data: Vec<u8> = (0..needed).map(|i| (i % 251) as u8).collect();
    assert!(LightField::new(&data[..needed - 1], layout).is_err());
    let lf = LightField::new(&data[..], layout).expect("a buffer of the validated size");

    let (r0, c0) = grid.center();
    let centre = lf.center_view();
    assert_eq!((centre.width(), centre.height()), (width, height));

    for probe in &input.probes {
        let (row, col) = (probe.row.get(), probe.col.get());
        let (x, y, ch) = (probe.x.get(), probe.y.get(), probe.channel.get());
        let inside_grid = row < grid.rows && col < grid.cols;
        let inside_view = x < width && y < height && ch < channels;
        let expected = (inside_grid && inside_view).then(|| {
            data[(row * grid.cols + col) * layout.view_stride
                + y * layout.row_stride
                + x * channels
                + ch]
        });
        assert_eq!(lf.pixel(row, col, x, y, ch), expected);
        assert_eq!(lf.view(row, col).is_ok(), inside_grid);
        if row == r0 && col == c0 {
            assert_eq!(centre.pixel(x, y, ch), expected);
        }
        if let Ok(view) = lf.view(row, col) {
            let row_len = view.row(y).map(<[u8]>::len);
            assert_eq!(row_len, (y < height).then_some(width * channels));
        }

        // Horizontal EPI through view row `row`, image row `y`: E(k, t) = view (row, k), pixel (t, y).
        match lf.epi_horizontal(row, y) {
            Ok(epi) => {
                assert!(row < grid.rows && y < height);
                let (k, t) = (col, x);
                let expected = (k < grid.cols && t < width && ch < channels).then(|| {
                    data[(row * grid.cols + k) * layout.view_stride
                        + y * layout.row_stride
                        + t * channels
                        + ch]
                });
                assert_eq!(epi.get(k, t, ch), expected);
            }
            Err(_) => assert!(row >= grid.rows || y >= height),
        }
        // Vertical EPI through view column `col`, image column `x`: E(k, t) = view (k, col), pixel (x, t).
        match lf.epi_vertical(col, x) {
            Ok(epi) => {
                assert!(col < grid.cols && x < width);
                let (k, t) = (row, y);
                let expected = (k < grid.rows && t < height && ch < channels).then(|| {
                    data[(k * grid.cols + col) * layout.view_stride
                        + t * layout.row_stride
                        + x * channels
                        + ch]
                });
                assert_eq!(epi.get(k, t, ch), expected);
            }
            Err(_) => assert!(col >= grid.cols || x >= width),
        }
    }
});
