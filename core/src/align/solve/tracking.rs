//! Tracking the centre view's corners into the other views, a batch of independent views
//! at a time: the first pass from a predicted disparity, the second from the first
//! estimate's positions and template shapes.

use heapless::Vec as FixedVec;

use super::observations::Corners;
use super::views::{baseline, row_col, TASK_BATCH};
use crate::align::model::{self, Mat};
use crate::align::pyramid::Pyramid;
use crate::align::track::{self, Pair};
use crate::align::{ViewMap, ViewTask, MAX_FEATURES};
use crate::error::{Error, Result};
use crate::geometry::Homography;
use crate::lightfield::{LightField, Sample};

/// Runs the tracking `job` for `views` (in index order) through `map`, [`TASK_BATCH`]
/// at a time, each task writing its view's row of the observation table `obs`; `check`
/// sees every finished task in order and stops at the first error.
pub(super) fn track_batches<M, J>(
    obs: &mut [f32],
    views: &[usize],
    view_pyr: &mut [f32],
    map: &mut M,
    job: &J,
    mut check: impl FnMut(&ViewTask<'_>) -> Result<()>,
) -> Result<()>
where
    M: ViewMap,
    J: Fn(&mut ViewTask<'_>, &mut [f32]) + Sync,
{
    for batch in views.chunks(TASK_BATCH) {
        let mut tasks: FixedVec<ViewTask<'_>, TASK_BATCH> = FixedVec::new();
        for (v, chunk) in obs.chunks_exact_mut(2 * MAX_FEATURES).enumerate() {
            if batch.contains(&v) {
                let _ = tasks.push(ViewTask::new(v, chunk));
            }
        }
        map.map(&mut tasks, view_pyr, job);
        for task in &tasks {
            check(task)?;
        }
    }
    Ok(())
}

/// What tracking into any view reads: the light field, the centre view's pyramid
/// (`centre_pyr`, laid out as `pyramid` says) and the centre view's corners.
pub(super) struct Centre<'c, 'l, S: Sample> {
    pub(super) lf: &'c LightField<'l, S>,
    pub(super) pyramid: &'c Pyramid,
    pub(super) centre_pyr: &'c [f32],
    pub(super) corners: &'c Corners<'c>,
}

/// The per-corner unknowns the second pass predicts from.
pub(super) struct Points<'p> {
    pub(super) x: &'p [f32; MAX_FEATURES],
    pub(super) y: &'p [f32; MAX_FEATURES],
    pub(super) d: &'p [f32; MAX_FEATURES],
    pub(super) solved: &'p [bool; MAX_FEATURES],
}

/// Which pyramid levels of a view to build.
#[derive(Clone, Copy)]
pub(super) enum Levels {
    All,
    /// Full resolution only.
    Base,
}

/// The pyramid of view `v`, built in `view_pyr`, paired with the centre view's.
pub(super) fn view_pair<'p, S: Sample>(
    lf: &LightField<'_, S>,
    pyramid: &'p Pyramid,
    centre_pyr: &'p [f32],
    view_pyr: &'p mut [f32],
    v: usize,
    levels: Levels,
) -> Result<Pair<'p>> {
    let got = view_pyr.len();
    let view_pyr = view_pyr
        .get_mut(..pyramid.len)
        .ok_or(Error::ScratchTooSmall {
            needed: pyramid.len,
            got,
        })?;
    let (r, c) = row_col(lf.grid(), v);
    let view = lf.view(r, c)?;
    match levels {
        Levels::All => pyramid.build(&view, view_pyr),
        Levels::Base => pyramid.build_base(&view, view_pyr),
    }
    Ok(Pair {
        pyramid,
        center: centre_pyr,
        view: view_pyr,
    })
}

/// First-pass tracking of the corners into `task`'s view: the search starts where the
/// `predicted` disparity puts each corner. Returns the number of corners found.
pub(super) fn track_first<S: Sample>(
    centre: &Centre<'_, '_, S>,
    view_pyr: &mut [f32],
    predicted: &[f32; MAX_FEATURES],
    task: &mut ViewTask<'_>,
) -> Result<usize> {
    let Centre {
        lf,
        pyramid,
        centre_pyr,
        corners,
    } = centre;
    let v = task.view;
    let pair = view_pair(lf, pyramid, centre_pyr, view_pyr, v, Levels::All)?;
    let b = baseline(lf.grid(), v);
    let mut found = 0;
    for ((i, c), &d) in corners.iter().enumerate().zip(predicted) {
        let guess = (c.x - d * b.0, c.y - d * b.1);
        let q = track::track(&pair, (c.x, c.y), guess, track::IDENTITY, usize::MAX);
        found += usize::from(q.is_some());
        task.set(i, q);
    }
    Ok(found)
}

/// Second-pass tracking into `task`'s view: positions and template shapes predicted by
/// the first estimate (`hs`, rectified → view; `to_rect`, centre view → rectified).
pub(super) fn track_second<S: Sample>(
    centre: &Centre<'_, '_, S>,
    view_pyr: &mut [f32],
    points: &Points<'_>,
    to_rect: &Mat,
    hs: &[Homography],
    task: &mut ViewTask<'_>,
) -> Result<usize> {
    let Centre {
        lf,
        pyramid,
        centre_pyr,
        corners,
    } = centre;
    let grid = lf.grid();
    let (width, height) = (lf.width(), lf.height());
    let o = ((width as f32 - 1.0) * 0.5, (height as f32 - 1.0) * 0.5);
    let v = task.view;
    let h_v = model::from_homography(hs.get(v).ok_or(Error::OutOfRange {
        what: "view",
        index: v,
        len: hs.len(),
    })?);
    let centre_to_view = h_v * to_rect;
    let shape = jacobian(&centre_to_view, o).unwrap_or(track::IDENTITY);
    // The second pass matches at full resolution only.
    let pair = view_pair(lf, pyramid, centre_pyr, view_pyr, v, Levels::Base)?;
    let b = baseline(grid, v);
    let mut found = 0;
    for (i, c) in corners.iter().enumerate() {
        let predicted = if points.solved.get(i) == Some(&true) {
            model::apply(
                &h_v,
                points.x[i] - points.d[i] * b.0,
                points.y[i] - points.d[i] * b.1,
            )
        } else {
            task.get(i)
        };
        let q = predicted.and_then(|g| track::track(&pair, (c.x, c.y), g, shape, 0));
        found += usize::from(q.is_some());
        task.set(i, q);
    }
    Ok(found)
}

/// Row-major 2 × 2 Jacobian of `m` at `p`.
pub(super) fn jacobian(m: &Mat, p: (f32, f32)) -> Option<[f32; 4]> {
    let at = model::apply(m, p.0, p.1)?;
    let ax = model::apply(m, p.0 + 1.0, p.1)?;
    let ay = model::apply(m, p.0, p.1 + 1.0)?;
    Some([ax.0 - at.0, ay.0 - at.0, ax.1 - at.1, ay.1 - at.1])
}
