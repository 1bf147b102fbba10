//! Which views of a located light field a run reads, so that only those are decoded
//! and an absent one is an error only when something reads it.
//!
//! The core decides ([`pipeline::stages_read_view`], [`pipeline::alignment_reads_view`]):
//! the EPI stage reads the centre row and column of the grid, the refinement its own
//! views (the same cross by default), the alignment a few more (the probe's corners in
//! auto mode, every view when the stages read views off the cross) but only among the
//! views that exist.

use lfdepth::pipeline::{self, Stages};
use lfdepth::Params;

use super::scene::ViewFiles;
use super::IoError;

/// The views to decode for one run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Needs {
    /// Per view (row-major): whether it is decoded.
    pub wanted: Vec<bool>,
    /// How many views the stages read.
    pub stages: usize,
    /// How many more the alignment reads (views that exist, no stage reads).
    pub alignment: usize,
}

impl Needs {
    /// A line for the user: which views are used, which absent.
    pub fn summary(&self, files: &ViewFiles) -> String {
        let absent = files.absent().len();
        let mut line = format!(
            "reading {} of the {}x{} views: {} the stages read",
            self.stages + self.alignment,
            files.grid.rows,
            files.grid.cols,
            self.stages
        );
        if self.alignment > 0 {
            line.push_str(&format!(", {} more for the alignment", self.alignment));
        }
        if absent > 0 {
            line.push_str(&format!("; {absent} absent (no chosen stage reads them)"));
        }
        line
    }
}

/// The views of `files` that `stages` with `params` read, plus those the alignment
/// reads among the views that exist. An absent view a stage reads is an error naming
/// it and what would do without it.
pub fn views_to_read(files: &ViewFiles, params: &Params, stages: Stages) -> Result<Needs, IoError> {
    let grid = files.grid;
    let mut needs = Needs {
        wanted: vec![false; grid.len()],
        stages: 0,
        alignment: 0,
    };
    for v in 0..grid.len() {
        let present = files.present.get(v) == Some(&true);
        if pipeline::stages_read_view(grid, params, stages, v) {
            if !present {
                return Err(absent_view_error(files, params, v));
            }
            needs.wanted[v] = true;
            needs.stages += 1;
        } else if present && pipeline::alignment_reads_view(grid, params, stages, v) {
            needs.wanted[v] = true;
            needs.alignment += 1;
        }
    }
    Ok(needs)
}

/// The error for absent view `v` that a chosen stage reads.
fn absent_view_error(files: &ViewFiles, params: &Params, v: usize) -> IoError {
    let grid = files.grid;
    let (r, c) = (v / grid.cols, v % grid.cols);
    let why = if pipeline::stages_read_view(grid, params, Stages::Epi, v) {
        let start = if params.sweep.enabled {
            "the plane sweep"
        } else {
            "the EPI stage"
        };
        format!(
            "{start} reads every view of the centre row and column of the {}x{} grid (this is row {}, column {}, counted from 0): add the view, or pass --grid RxC if that is not the grid",
            grid.rows, grid.cols, r, c
        )
    } else {
        "the refinement reads it (its view set reaches beyond the centre row and column): pass --refine 0 or --stage epi to do without it, or add the view".into()
    };
    IoError::format(format!("is missing: {why}")).in_file(&files.paths[v])
}
