//! How much of the alignment estimate is per-view tracking (what the CLI's
//! `ParallelViews` spreads over threads) and how much is the serial alternation: on-CPU
//! time of this thread inside and outside the view maps, per estimate of a misaligned
//! 9×9×512² `mixed` array (cross views and every view), with the speed-up Amdahl's law
//! allows on 2, 4 and 8 threads. Linux only (`/proc/thread-self/schedstat`). The share
//! quoted in docs/stages/align.md:
//!
//! ```text
//! cargo run --release -p lfdepth-cli --example align_parallel_share
//! ```

use lfdepth::align::{self, AlignMode, AlignParams, AlignedViews};
use lfdepth::synth::{self, Misalignment, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography, LightField};

fn main() {
    fn thread_cpu() -> std::time::Duration {
        let s = std::fs::read_to_string("/proc/thread-self/schedstat")
            .expect("this measurement reads Linux's /proc/thread-self/schedstat");
        let nanos = s.split_whitespace().next().and_then(|n| n.parse().ok());
        std::time::Duration::from_nanos(nanos.expect("a number first in schedstat"))
    }
    /// The serial map, timing the jobs.
    struct Timed(std::time::Duration);
    impl align::ViewMap for Timed {
        fn map<F>(&mut self, tasks: &mut [align::ViewTask<'_>], scratch: &mut [f32], job: &F)
        where
            F: Fn(&mut align::ViewTask<'_>, &mut [f32]) + Sync,
        {
            let start = thread_cpu();
            align::Serial.map(tasks, scratch, job);
            self.0 += thread_cpu() - start;
        }
    }
    // A misaligned `mixed` array, 9×9×512² RGB (the misalignment `lfdepth synth --misalign` draws).
    let mut spec = SynthSpec::new(SceneKind::Mixed, Grid::new(9, 9), 512, 512);
    spec.seed = 1;
    spec.misalign = Some(Misalignment {
        max_rotation_deg: 2.0,
        max_translation_px: 3.0,
        max_scale: 0.01,
        max_perspective: 0.002,
    });
    let mut data = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; 512 * 512];
    let mut truth = vec![Homography::IDENTITY; 81];
    synth::render(&spec, &mut data, &mut gt, &mut truth).unwrap();
    let layout = spec.layout();
    let lf = LightField::new(&data[..], layout).unwrap();
    for views in [AlignedViews::Cross, AlignedViews::All] {
        let params = AlignParams {
            mode: AlignMode::On,
            views,
            ..AlignParams::default()
        };
        let mut hs = vec![Homography::IDENTITY; 81];
        let mut scratch = vec![0.0f32; align::scratch_len(&layout, &params).unwrap()];
        let mut timed = Timed(std::time::Duration::ZERO);
        let start = thread_cpu();
        for _ in 0..5 {
            align::estimate_with(&lf, &params, &mut hs, &mut scratch, &mut timed).unwrap();
        }
        let total = thread_cpu() - start;
        let share = timed.0.as_secs_f64() / total.as_secs_f64();
        eprintln!(
            "{views:?}: on-CPU {:.1} ms per estimate, of which per-view tracking {:.1} ms ({:.0} %); Amdahl bound on 2 / 4 / 8 threads: {:.2}× / {:.2}× / {:.2}×",
            total.as_secs_f64() * 200.0,
            timed.0.as_secs_f64() * 200.0,
            100.0 * share,
            1.0 / (1.0 - share + share / 2.0),
            1.0 / (1.0 - share + share / 4.0),
            1.0 / (1.0 - share + share / 8.0),
        );
    }
}
