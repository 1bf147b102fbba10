extern crate std;
use std::vec;
use std::vec::Vec;

use super::*;
use crate::epi::{EpiParams, Fusion};
use crate::lightfield::LightField;
use crate::pipeline::{self, Stages};
use crate::refine::RefineParams;
use crate::scalar::Scalar;
use crate::synth::{self, SceneKind, SynthSpec};
use crate::tv::TvParams;
use crate::Q16;

/// Stream parameters. The exhaustive search: the coarse-to-fine one groups samples into
/// runs along the whole line, so a cropped line agrees with the frame's only to ~1e-6 px.
fn params(tile: usize, halo: usize, min: f32, max: f32) -> Params {
    Params {
        epi: EpiParams {
            range: DisparityRange::Fixed { min, max },
            search: crate::epi::Search::Exhaustive,
            ..EpiParams::default()
        },
        refine: RefineParams::off(),
        median: crate::median::MedianParams::off(),
        geofill: crate::geofill::GeoFillParams::off(),
        tv: TvParams {
            tile,
            halo,
            max_iterations: 60,
            ..TvParams::default()
        },
        sweep: crate::planesweep::PlaneSweepParams::off(),
        ..Params::default()
    }
}

fn render(spec: &SynthSpec) -> Vec<u8> {
    let mut views = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; spec.width * spec.height];
    let mut homographies = vec![crate::Homography::IDENTITY; spec.grid.len()];
    synth::render(spec, &mut views, &mut gt, &mut homographies).unwrap();
    views
}

/// Copies rows `rows` of every cross view of a whole frame into a packed band.
fn fill_band(views: &[u8], layout: &Layout, rows: Range<usize>, band: &mut Vec<u8>) {
    let row_len = layout.width * layout.channels;
    band.clear();
    band.resize(
        CrossBand::<u8>::slots(layout.grid) * rows.len() * row_len,
        0,
    );
    let (r0, c0) = layout.grid.center();
    for r in 0..layout.grid.rows {
        for c in 0..layout.grid.cols {
            let Some(slot) = CrossBand::<u8>::slot(layout.grid, r, c) else {
                continue;
            };
            assert!(r == r0 || c == c0);
            for (i, y) in rows.clone().enumerate() {
                let from = layout.grid.index(r, c) * layout.view_stride + y * layout.row_stride;
                let to = (slot * rows.len() + i) * row_len;
                band[to..to + row_len].copy_from_slice(&views[from..from + row_len]);
            }
        }
    }
}

/// Streams a whole frame band by band; returns the disparity and confidence maps.
fn stream<T: Scalar>(plan: &StreamPlan, views: &[u8]) -> (Vec<f32>, Vec<f32>) {
    let layout = *plan.plan().layout();
    let mut d = vec![f32::NAN; layout.pixels()];
    let mut c = vec![f32::NAN; layout.pixels()];
    let mut scratch = vec![T::ZERO; plan.scratch_len()];
    let mut maps = vec![0.0f32; plan.map_scratch_len()];
    let mut band = Vec::new();
    for b in 0..plan.bands() {
        let rows = plan.input_rows(b).unwrap();
        assert!(rows.len() <= plan.max_input_rows());
        fill_band(views, &layout, rows.clone(), &mut band);
        assert!(band.len() <= plan.band_len());
        let input = CrossBand::packed(&band, &layout, rows).unwrap();
        let out = plan.output_rows(b).unwrap();
        let span = out.start * layout.width..out.end * layout.width;
        plan.process_band(
            b,
            &input,
            &mut d[span.clone()],
            &mut c[span],
            &mut scratch,
            &mut maps,
        )
        .unwrap();
    }
    (d, c)
}

fn whole_frame<T: Scalar>(plan: &Plan, views: &[u8]) -> (Vec<f32>, Vec<f32>) {
    let lf = LightField::new(views, *plan.layout()).unwrap();
    let mut d = vec![0.0; plan.pixels()];
    let mut c = vec![0.0; plan.pixels()];
    let mut scratch = vec![T::ZERO; pipeline::scratch_len(plan)];
    let mut maps = vec![0.0f32; pipeline::map_scratch_len(plan)];
    pipeline::run(
        plan,
        &lf,
        Stages::Full,
        pipeline::RunOutput {
            disparity: &mut d,
            confidence: &mut c,
            history: &mut [],
        },
        pipeline::RunScratch {
            kernel: &mut scratch,
            maps: &mut maps,
        },
        &mut |_| core::ops::ControlFlow::Continue(()),
    )
    .unwrap();
    (d, c)
}

fn assert_same(stream: &[f32], whole: &[f32], width: usize, what: &str) {
    for (i, (s, w)) in stream.iter().zip(whole).enumerate() {
        assert!(
            s.to_bits() == w.to_bits(),
            "{what} at ({}, {}): stream {s} vs whole frame {w}",
            i % width,
            i / width
        );
    }
}

#[test]
fn stream_equals_the_whole_frame_pipeline() {
    // 9×9 RGB, f32: several bands and tiles, clipped ones at the right and bottom.
    let spec = SynthSpec::new(SceneKind::Mixed, Grid::new(9, 9), 90, 76);
    let views = render(&spec);
    let plan = StreamPlan::new(spec.layout(), params(24, 8, -1.5, 1.5)).unwrap();
    assert_eq!(plan.bands(), 4);
    let (sd, sc) = stream::<f32>(&plan, &views);
    let (wd, wc) = whole_frame::<f32>(plan.plan(), &views);
    assert_same(&sd, &wd, spec.width, "f32 disparity");
    assert_same(&sc, &wc, spec.width, "f32 confidence");
}

/// The colour weight runs in the stream's line loads as in the whole frame's, in f32
/// and Q16.16.
#[test]
fn stream_with_the_colour_weight_equals_the_whole_frame_pipeline() {
    let spec = SynthSpec::new(SceneKind::Mixed, Grid::new(9, 9), 70, 60);
    let views = render(&spec);
    let mut p = params(24, 8, -1.5, 1.5);
    p.epi.chroma = 0.0;
    p.epi.chroma_knee = 0.3;
    let plan = StreamPlan::new(spec.layout(), p).unwrap();
    let (sd, sc) = stream::<f32>(&plan, &views);
    let (wd, wc) = whole_frame::<f32>(plan.plan(), &views);
    assert_same(&sd, &wd, spec.width, "f32 disparity");
    assert_same(&sc, &wc, spec.width, "f32 confidence");
    let (plain, _) = whole_frame::<f32>(
        StreamPlan::new(spec.layout(), params(24, 8, -1.5, 1.5))
            .unwrap()
            .plan(),
        &views,
    );
    assert_ne!(wd, plain, "the weight changes the map");
    let (sd, _) = stream::<Q16>(&plan, &views);
    let (wd, _) = whole_frame::<Q16>(plan.plan(), &views);
    assert_same(&sd, &wd, spec.width, "Q16 disparity");
}

#[test]
fn q16_gray_stream_on_a_non_square_grid_equals_the_pipeline() {
    let mut spec = SynthSpec::new(SceneKind::Occlusion, Grid::new(5, 7), 60, 52);
    spec.channels = 1;
    spec.disparity_min = -1.0;
    spec.disparity_max = 2.0;
    let views = render(&spec);
    let mut p = params(20, 6, -1.0, 2.0);
    p.epi.color = ColorMode::Gray;
    p.epi.fusion = Fusion::Weighted;
    let plan = StreamPlan::new(spec.layout(), p).unwrap();
    let (sd, sc) = stream::<Q16>(&plan, &views);
    let (wd, wc) = whole_frame::<Q16>(plan.plan(), &views);
    assert_same(&sd, &wd, spec.width, "Q16 disparity");
    assert_same(&sc, &wc, spec.width, "Q16 confidence");
}

/// [`params`] with the default weighted median (four passes of radius 7, before TV).
fn with_median(p: Params) -> Params {
    Params {
        median: crate::median::MedianParams::default(),
        ..p
    }
}

#[test]
fn stream_with_the_median_equals_the_whole_frame_pipeline() {
    // 9×9 RGB, f32: the median's halo (32 px) is wider than the tiles, so regions are
    // clipped at every side of the frame and interior ones exist only in the middle.
    let spec = SynthSpec::new(SceneKind::Mixed, Grid::new(9, 9), 150, 118);
    let views = render(&spec);
    let plan = StreamPlan::new(spec.layout(), with_median(params(24, 8, -1.5, 1.5))).unwrap();
    assert_eq!(plan.median_halo(), 32);
    assert_eq!(plan.bands(), 5);
    let (sd, sc) = stream::<f32>(&plan, &views);
    let (wd, wc) = whole_frame::<f32>(plan.plan(), &views);
    assert_same(&sd, &wd, spec.width, "f32 disparity");
    assert_same(&sc, &wc, spec.width, "f32 confidence");
    // The median changed the map: the test compares more than EPI → TV.
    let no_median = StreamPlan::new(spec.layout(), params(24, 8, -1.5, 1.5)).unwrap();
    let (nd, _) = stream::<f32>(&no_median, &views);
    assert!(nd.iter().zip(&sd).filter(|(a, b)| a != b).count() > 100);
}

#[test]
fn q16_gray_stream_with_the_median_equals_the_pipeline() {
    let mut spec = SynthSpec::new(SceneKind::Occlusion, Grid::new(5, 7), 84, 70);
    spec.channels = 1;
    spec.disparity_min = -1.0;
    spec.disparity_max = 2.0;
    let views = render(&spec);
    let mut p = with_median(params(20, 6, -1.0, 2.0));
    p.epi.color = ColorMode::Gray;
    p.median.passes = 2;
    p.median.radius = 4;
    let plan = StreamPlan::new(spec.layout(), p).unwrap();
    assert_eq!(plan.median_halo(), 10);
    let (sd, sc) = stream::<Q16>(&plan, &views);
    let (wd, wc) = whole_frame::<Q16>(plan.plan(), &views);
    assert_same(&sd, &wd, spec.width, "Q16 disparity");
    assert_same(&sc, &wc, spec.width, "Q16 confidence");
}

/// With the weighted median, a 9×9 RGB stream (tiles 16 + 8) needs at most 384 KiB of
/// scratch at any width up to 2048 and any height, the same for every frame larger than
/// one region; its input band does not grow with the height.
#[test]
fn median_stream_scratch_fits_384_kib_at_any_width_and_height() {
    let p = with_median(params(16, 8, -1.5, 1.5));
    let plan = |width: usize, height: usize| {
        StreamPlan::new(Layout::packed(Grid::new(9, 9), width, height, 3), p).unwrap()
    };
    let reference = plan(512, 512);
    let bytes = reference.scratch_bytes(4);
    assert!(bytes <= 384 * 1024, "{bytes} bytes");
    for width in [200, 512, 1000, 1536, 2048] {
        for height in [200, 384, 1080, 2048, 4000] {
            let stream = plan(width, height);
            assert_eq!(stream.scratch_bytes(4), bytes, "{width}×{height}");
            assert_eq!(stream.max_input_rows(), reference.max_input_rows());
        }
    }
    // The median's halo is what grows the input band.
    let without = StreamPlan::new(
        Layout::packed(Grid::new(9, 9), 512, 512, 3),
        params(16, 8, -1.5, 1.5),
    )
    .unwrap();
    assert_eq!(
        reference.max_input_rows(),
        without.max_input_rows() + 2 * 32
    );
}

/// The embedded goal: a 9×9 RGB light field of 512² streamed with at most 256 KiB of
/// scratch, and the same bytes at 1024².
#[test]
fn scratch_fits_256_kib_and_does_not_grow_with_the_frame() {
    let p = params(36, 16, -1.5, 1.5);
    let bytes = |side: usize| {
        let layout = Layout::packed(Grid::new(9, 9), side, side, 3);
        StreamPlan::new(layout, p).unwrap().scratch_bytes(4)
    };
    let (small, large) = (bytes(512), bytes(1024));
    assert!(small <= 256 * 1024, "{small} bytes");
    assert_eq!(small, large);
    assert_eq!(small, bytes(2000));
    // Input band rows do not grow with the height either.
    let rows = |side: usize| {
        let layout = Layout::packed(Grid::new(9, 9), side, side, 3);
        StreamPlan::new(layout, p).unwrap().max_input_rows()
    };
    assert_eq!(rows(512), rows(1024));
}

#[test]
fn bad_streams_are_refused_with_errors() {
    let layout = Layout::packed(Grid::new(9, 9), 64, 64, 3);
    let auto = Params {
        refine: RefineParams::off(),
        median: crate::median::MedianParams::off(),
        geofill: crate::geofill::GeoFillParams::off(),
        sweep: crate::planesweep::PlaneSweepParams::off(),
        ..Params::default()
    };
    assert!(matches!(
        StreamPlan::new(layout, auto),
        Err(Error::InvalidParameter {
            name: "epi.range",
            ..
        })
    ));
    let mut median = params(32, 8, -1.0, 1.0);
    median.median = crate::median::MedianParams {
        before_tv: false,
        ..crate::median::MedianParams::default()
    };
    assert!(matches!(
        StreamPlan::new(layout, median),
        Err(Error::InvalidParameter {
            name: "median.before_tv",
            ..
        })
    ));
    median.median.before_tv = true;
    assert_eq!(StreamPlan::new(layout, median).unwrap().median_halo(), 32);
    let mut sweeps = params(32, 8, -1.0, 1.0);
    sweeps.tv.sweeps = 1;
    assert!(matches!(
        StreamPlan::new(layout, sweeps),
        Err(Error::InvalidParameter {
            name: "tv.sweeps",
            ..
        })
    ));
    let mut refine = params(32, 8, -1.0, 1.0);
    refine.refine = RefineParams::on();
    assert!(matches!(
        StreamPlan::new(layout, refine),
        Err(Error::InvalidParameter {
            name: "refine.enabled",
            ..
        })
    ));
    let mut align = params(32, 8, -1.0, 1.0);
    align.align.mode = crate::align::AlignMode::On;
    assert!(matches!(
        StreamPlan::new(layout, align),
        Err(Error::InvalidParameter {
            name: "align.mode",
            ..
        })
    ));
    for rail in [Grid::new(1, 9), Grid::new(9, 1)] {
        let rail = Layout::packed(rail, 64, 64, 3);
        assert!(matches!(
            StreamPlan::new(rail, params(32, 8, -1.0, 1.0)),
            Err(Error::InvalidParameter { name: "grid", .. })
        ));
    }
    let plan = StreamPlan::new(layout, params(32, 8, -1.0, 1.0)).unwrap();
    let rows = plan.input_rows(1).unwrap();
    let band = vec![0u8; plan.band_len()];
    // A band that misses the first row band 1 needs.
    let short = CrossBand::packed(&band, &layout, rows.start + 1..rows.end).unwrap();
    let mut d = vec![0.0; 32 * 64];
    let mut c = vec![0.0; 32 * 64];
    let mut scratch = vec![0.0f32; plan.scratch_len()];
    let mut maps = vec![0.0f32; plan.map_scratch_len()];
    assert!(matches!(
        plan.process_band(1, &short, &mut d, &mut c, &mut scratch, &mut maps),
        Err(Error::OutOfRange { .. })
    ));
    let input = CrossBand::packed(&band, &layout, rows).unwrap();
    let cut = plan.scratch_len() - 1;
    assert!(matches!(
        plan.process_band(1, &input, &mut d, &mut c, &mut scratch[..cut], &mut maps),
        Err(Error::ScratchTooSmall { .. })
    ));
    assert!(matches!(
        plan.process_band(1, &input, &mut d[1..], &mut c, &mut scratch, &mut maps),
        Err(Error::OutputSize { .. })
    ));
    assert!(matches!(
        plan.process_band(2, &input, &mut d, &mut c, &mut scratch, &mut maps),
        Err(Error::OutOfRange { what: "band", .. })
    ));
    assert!(matches!(
        CrossBand::packed(&band[..10], &layout, 0..8),
        Err(Error::BufferTooSmall { .. })
    ));
    assert_eq!(CrossBand::<u8>::slot(layout.grid, 0, 0), None);
    assert_eq!(CrossBand::<u8>::slot(layout.grid, 8, 4), Some(16));
    assert_eq!(CrossBand::<u8>::slot(layout.grid, 4, 4), Some(4));
}

#[test]
fn a_stream_refuses_the_refill() {
    let params = Params {
        geofill: crate::geofill::GeoFillParams {
            enabled: true,
            ..crate::geofill::GeoFillParams::default()
        },
        sweep: crate::planesweep::PlaneSweepParams::off(),
        ..Params::default()
    };
    let params = Params {
        refine: crate::refine::RefineParams::off(),
        median: crate::median::MedianParams::off(),
        tv: crate::tv::TvParams {
            sweeps: 0,
            ..params.tv
        },
        epi: crate::epi::EpiParams {
            range: crate::epi::DisparityRange::Fixed {
                min: -1.0,
                max: 1.0,
            },
            ..params.epi
        },
        ..params
    };
    let layout = Layout::packed(Grid::new(3, 3), 48, 24, 3);
    assert!(matches!(
        StreamPlan::new(layout, params),
        Err(Error::InvalidParameter {
            name: "geofill.enabled",
            ..
        })
    ));
    let off = Params {
        geofill: crate::geofill::GeoFillParams::off(),
        ..params
    };
    assert!(StreamPlan::new(layout, off).is_ok());
    let sweep = Params {
        sweep: crate::planesweep::PlaneSweepParams {
            enabled: true,
            ..Default::default()
        },
        ..off
    };
    assert!(matches!(
        StreamPlan::new(layout, sweep),
        Err(Error::InvalidParameter {
            name: "sweep.enabled",
            ..
        })
    ));
}
