//! Loading a light field from a folder of views.
//!
//! Views are found by file name:
//! - `input_CamNNN.png` (the HCI benchmark): row-major index from 0; the grid comes from
//!   `--grid`, else `parameters.cfg` (`num_cams_y` × `num_cams_x`), else the smallest
//!   square holding the highest index;
//! - `NAME_RR_CC.png`: row and column, 0- or 1-based (the smallest number found decides);
//!   the grid comes from `--grid`, `parameters.cfg` or the largest row and column;
//! - anything else through `--pattern` (see [`super::pattern`]).
//!
//! Every view's header is read first: the views must agree on size and sample format
//! and fit the caps of [`super::limits`], else nothing is decoded and the error names
//! the odd view or the flag that raises the cap. Views are then decoded in parallel.
//! 8-bit images are kept as `u8`, 16-bit ones become `f32` in `[0, 1]`; a gray+alpha
//! image keeps only its gray channel.

use std::path::{Path, PathBuf};

use lfdepth::{Grid, Layout};
use rayon::prelude::*;

use super::cfg::{self, SceneConfig};
use super::limits::Limits;
use super::pattern::{Numbers, Pattern};
use super::png::{self as pngio, Image, Samples};
use super::IoError;

/// The HCI benchmark's view names.
pub const HCI_PATTERN: &str = "input_Cam{index:03}.png";
/// The camera parameters file of a scene.
pub const CONFIG_FILE: &str = "parameters.cfg";
/// The ground-truth disparity of a scene's centre view.
pub const GROUND_TRUTH_FILE: &str = "gt_disp_lowres.pfm";

/// How to find the views.
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// A file-name pattern; `None` detects one.
    pub pattern: Option<String>,
    /// The grid; `None` takes it from `parameters.cfg` or the file names.
    pub grid: Option<Grid>,
}

/// The views of a scene, located but not yet decoded.
#[derive(Clone, Debug)]
pub struct ViewFiles {
    /// The folder.
    pub dir: PathBuf,
    /// The view grid.
    pub grid: Grid,
    /// One file per view, row-major.
    pub paths: Vec<PathBuf>,
    /// The pattern the names follow.
    pub pattern: String,
    /// `parameters.cfg`, when present.
    pub config: Option<SceneConfig>,
}

/// Decoded view samples, packed view after view in row-major grid order.
#[derive(Clone, Debug, PartialEq)]
pub enum Views {
    /// From 8-bit images.
    U8(Vec<u8>),
    /// From 16-bit images, scaled to `[0, 1]`.
    F32(Vec<f32>),
}

/// A loaded light field.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Where the views were found.
    pub files: ViewFiles,
    /// The packed layout of [`Scene::views`].
    pub layout: Layout,
    /// The samples.
    pub views: Views,
}

impl Scene {
    /// The folder.
    pub fn dir(&self) -> &Path {
        &self.files.dir
    }
    /// `gt_disp_lowres.pfm` in the scene folder, when it exists.
    pub fn ground_truth_path(&self) -> Option<PathBuf> {
        let p = self.files.dir.join(GROUND_TRUTH_FILE);
        p.is_file().then_some(p)
    }
}

/// A list of names for a message: the first few, then how many more.
fn name_list(names: &[String]) -> String {
    const SHOWN: usize = 6;
    let mut s = names
        .iter()
        .take(SHOWN)
        .cloned()
        .collect::<Vec<_>>()
        .join(", ");
    if names.len() > SHOWN {
        s.push_str(&format!(" and {} more", names.len() - SHOWN));
    }
    s
}

fn folder_error(dir: &Path, message: String) -> IoError {
    IoError::format(message).in_file(dir)
}

/// Names (not paths) of the entries of `dir`, sorted: plain files and anything else, so
/// that a view name taken by a folder, a FIFO or a broken or looping link is reported as
/// such when it is read, not as a missing view.
fn file_names(dir: &Path) -> Result<Vec<String>, IoError> {
    let entries = std::fs::read_dir(dir).map_err(|e| IoError::os(dir, "list", e))?;
    let mut names = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| IoError::os(dir, "list", e))?;
        if let Some(name) = entry.file_name().to_str() {
            names.push(name.to_string());
        }
    }
    names.sort();
    Ok(names)
}

/// Guesses the naming pattern from the files present.
fn detect_pattern(dir: &Path, names: &[String]) -> Result<Pattern, IoError> {
    let hci = Pattern::parse(HCI_PATTERN)?;
    if names.iter().any(|n| hci.matches(n).is_some()) {
        return Ok(hci);
    }
    // NAME_RR_CC.png: group by NAME.
    let mut prefixes: Vec<String> = Vec::new();
    for name in names {
        let Some(stem) = name.strip_suffix(".png") else {
            continue;
        };
        let mut parts = stem.rsplitn(3, '_');
        let (Some(col), Some(row), Some(prefix)) = (parts.next(), parts.next(), parts.next())
        else {
            continue;
        };
        let digits =
            |s: &str| !s.is_empty() && s.len() <= 9 && s.bytes().all(|b| b.is_ascii_digit());
        if digits(row) && digits(col) && !prefixes.iter().any(|p| p == prefix) {
            prefixes.push(prefix.to_string());
        }
    }
    match prefixes.as_slice() {
        [prefix] => {
            let escaped = prefix.replace(['{', '}'], "");
            if escaped != *prefix {
                return Err(folder_error(
                    dir,
                    format!("view names starting `{prefix}` contain braces: rename the files"),
                ));
            }
            Pattern::parse(&format!("{prefix}_{{row}}_{{col}}.png"))
        }
        [] => {
            let pngs = names.iter().filter(|n| n.ends_with(".png")).count();
            Err(folder_error(
                dir,
                if pngs == 0 {
                    "holds no PNG views: expected input_CamNNN.png or NAME_RR_CC.png files".into()
                } else {
                    format!(
                        "none of its {pngs} PNG files is named like a view (input_CamNNN.png or NAME_RR_CC.png): pass --pattern, e.g. --pattern 'view_{{row}}_{{col}}.png'"
                    )
                },
            ))
        }
        many => Err(folder_error(
            dir,
            format!(
                "holds views of several light fields ({}): pass --pattern to choose, e.g. --pattern '{}_{{row}}_{{col}}.png'",
                name_list(&many.iter().map(|p| format!("{p}_RR_CC.png")).collect::<Vec<_>>()),
                many[0]
            ),
        )),
    }
}

/// Why `path` (not a folder) cannot be the folder holding the `what`: it does not exist,
/// or what it is instead.
pub fn not_a_folder(path: &Path, what: &str) -> String {
    match std::fs::metadata(path) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            format!("does not exist: give the folder that holds the {what}")
        }
        Err(e) => format!("cannot be opened ({e}): give the folder that holds the {what}"),
        Ok(meta) => format!(
            "is {}, not a folder: give the folder that holds the {what}",
            super::kind_of(&meta.file_type())
        ),
    }
}

/// Grid position of a matched file.
struct Found {
    name: String,
    numbers: Numbers,
}

/// The smallest square grid holding `count` views.
fn square_for(count: usize) -> usize {
    let mut side = 1;
    while side * side < count {
        side += 1;
    }
    side
}

/// Finds the views of the light field in `dir` without decoding them.
pub fn locate(dir: &Path, options: &LoadOptions) -> Result<ViewFiles, IoError> {
    if !dir.is_dir() {
        return Err(folder_error(dir, not_a_folder(dir, "views")));
    }
    let config_path = dir.join(CONFIG_FILE);
    let config = if config_path.is_file() {
        Some(cfg::read(&config_path)?)
    } else {
        None
    };
    let names = file_names(dir)?;
    let pattern = match &options.pattern {
        Some(p) => Pattern::parse(p)?,
        None => detect_pattern(dir, &names)?,
    };
    let found: Vec<Found> = names
        .iter()
        .filter_map(|n| {
            pattern.matches(n).map(|numbers| Found {
                name: n.clone(),
                numbers,
            })
        })
        .collect();
    if found.is_empty() {
        return Err(folder_error(
            dir,
            format!(
                "holds no views named like `{}`: check the folder or --pattern",
                pattern.as_str()
            ),
        ));
    }
    let digits = found
        .iter()
        .map(|f| f.numbers.digits)
        .min()
        .unwrap_or(1)
        .max(1);
    // Position (row, col) of each file, 0-based.
    let positions: Vec<(usize, usize)>;
    let grid: Grid;
    let base: usize;
    let cfg_grid = config
        .as_ref()
        .and_then(|c| c.grid())
        .map(|(r, c)| Grid::new(r, c));
    if pattern.uses_index() {
        let indices: Vec<usize> = found.iter().map(|f| f.numbers.index.unwrap_or(0)).collect();
        let min = indices.iter().copied().min().unwrap_or(0);
        // The HCI benchmark numbers from 0 even if Cam000 were missing.
        base = if pattern.as_str() == HCI_PATTERN || min == 0 {
            0
        } else {
            1
        };
        let max = indices.iter().copied().max().unwrap_or(0);
        grid = match options.grid.or(cfg_grid) {
            Some(g) => g,
            None => {
                let side = square_for(max - base + 1);
                Grid::new(side, side)
            }
        };
        let cols = grid.cols.max(1);
        positions = indices
            .iter()
            .map(|i| ((i - base) / cols, (i - base) % cols))
            .collect();
    } else {
        let rows: Vec<usize> = found.iter().map(|f| f.numbers.row.unwrap_or(0)).collect();
        let cols: Vec<usize> = found.iter().map(|f| f.numbers.col.unwrap_or(0)).collect();
        let min = rows.iter().chain(&cols).copied().min().unwrap_or(0);
        base = if min == 0 { 0 } else { 1 };
        grid = match options.grid.or(cfg_grid) {
            Some(g) => g,
            None => Grid::new(
                rows.iter().max().unwrap_or(&0) - base + 1,
                cols.iter().max().unwrap_or(&0) - base + 1,
            ),
        };
        positions = rows
            .iter()
            .zip(&cols)
            .map(|(r, c)| (r - base, c - base))
            .collect();
    }
    let g = grid;
    if !(lfdepth::lightfield::GRID_MIN..=lfdepth::lightfield::GRID_MAX).contains(&g.rows)
        || !(lfdepth::lightfield::GRID_MIN..=lfdepth::lightfield::GRID_MAX).contains(&g.cols)
    {
        return Err(IoError::core(
            dir,
            lfdepth::Error::GridSize {
                rows: g.rows,
                cols: g.cols,
            },
        ));
    }
    let mut slots: Vec<Option<usize>> = vec![None; g.len()];
    let mut extra = Vec::new();
    for (k, &(r, c)) in positions.iter().enumerate() {
        if r >= g.rows || c >= g.cols {
            extra.push(found[k].name.clone());
            continue;
        }
        let slot = &mut slots[g.index(r, c)];
        if let Some(other) = *slot {
            return Err(folder_error(
                dir,
                format!(
                    "{} and {} are the same view (row {}, column {}): remove one",
                    found[other].name,
                    found[k].name,
                    r + base,
                    c + base
                ),
            ));
        }
        *slot = Some(k);
    }
    if !extra.is_empty() {
        return Err(folder_error(
            dir,
            format!(
                "{} view(s) do not fit the {}x{} grid: {}; pass the right --grid RxC or remove them",
                extra.len(),
                g.rows,
                g.cols,
                name_list(&extra)
            ),
        ));
    }
    let missing: Vec<String> = (0..g.len())
        .filter(|&i| slots[i].is_none())
        .map(|i| {
            let (r, c) = (i / g.cols, i % g.cols);
            pattern.render(
                Numbers {
                    row: Some(r + base),
                    col: Some(c + base),
                    index: Some(i + base),
                    digits,
                },
                digits,
            )
        })
        .collect();
    if !missing.is_empty() {
        return Err(folder_error(
            dir,
            format!(
                "{} of the {}x{} views are missing: {}",
                missing.len(),
                g.rows,
                g.cols,
                name_list(&missing)
            ),
        ));
    }
    let paths = slots
        .iter()
        .flatten()
        .map(|&k| dir.join(&found[k].name))
        .collect();
    Ok(ViewFiles {
        dir: dir.to_path_buf(),
        grid,
        paths,
        pattern: pattern.as_str().to_string(),
        config,
    })
}

/// Locates and decodes the views of the light field in `dir` within the default
/// [`Limits`].
pub fn load(dir: &Path, options: &LoadOptions) -> Result<Scene, IoError> {
    load_limited(dir, options, &Limits::default())
}

/// Locates and decodes the views of the light field in `dir` within `limits`.
pub fn load_limited(dir: &Path, options: &LoadOptions, limits: &Limits) -> Result<Scene, IoError> {
    read_views(locate(dir, options)?, limits)
}

/// The most common value of `keys` (the first view's on a tie) and the indices of the
/// views that differ from it.
fn odd_ones<K: Copy + PartialEq>(keys: &[K]) -> (K, Vec<usize>) {
    let mut best = (keys[0], 0);
    for &k in keys {
        let count = keys.iter().filter(|&&o| o == k).count();
        if count > best.1 {
            best = (k, count);
        }
    }
    let odd = (0..keys.len()).filter(|&i| keys[i] != best.0).collect();
    (best.0, odd)
}

/// The error for views that differ from the rest in `what` (a size, a sample format):
/// names the odd views, and one view that has the common value.
fn odd_views_error(
    files: &ViewFiles,
    odd: &[usize],
    odd_value: String,
    common_value: String,
    what: &str,
) -> IoError {
    let good = (0..files.paths.len())
        .find(|i| !odd.contains(i))
        .unwrap_or(0);
    let name = |i: usize| {
        files.paths[i]
            .file_name()
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
    };
    let others = if odd.len() > 1 {
        let names: Vec<String> = odd[1..].iter().map(|&i| name(i)).collect();
        format!(" (so do {})", name_list(&names))
    } else {
        String::new()
    };
    IoError::format(format!(
        "is {odd_value} but the other {} views (e.g. {}) are {common_value}{others}: {what}",
        files.paths.len() - odd.len(),
        name(good),
    ))
    .in_file(&files.paths[odd[0]])
}

/// Decodes located views: first every header, which must agree on size and sample
/// format and fit `limits` (nothing is decoded otherwise), then the pixels.
pub fn read_views(files: ViewFiles, limits: &Limits) -> Result<Scene, IoError> {
    let dir = files.dir.clone();
    let read: Vec<Result<pngio::Header, IoError>> = files
        .paths
        .par_iter()
        .map(|p| pngio::read_header(p, limits.max_view_pixels))
        .collect();
    // The first failing view in grid order, whatever the threads' timing.
    let headers = read.into_iter().collect::<Result<Vec<_>, _>>()?;
    let sizes: Vec<(usize, usize)> = headers.iter().map(|h| (h.width, h.height)).collect();
    let ((width, height), odd) = odd_ones(&sizes);
    if !odd.is_empty() {
        let (w, h) = sizes[odd[0]];
        return Err(odd_views_error(
            &files,
            &odd,
            format!("{w}x{h} pixels"),
            format!("{width}x{height}"),
            "all views must have the same size",
        ));
    }
    let formats: Vec<(usize, u8)> = headers.iter().map(|h| (h.channels, h.bit_depth)).collect();
    let ((channels, depth), odd) = odd_ones(&formats);
    if !odd.is_empty() {
        let (c, d) = formats[odd[0]];
        return Err(odd_views_error(
            &files,
            &odd,
            format!("{c} channel(s) of {d} bits"),
            format!("{channels} of {depth}"),
            "save all views alike",
        ));
    }
    limits
        .check_light_field(files.paths.len(), width, height)
        .map_err(|e| IoError::format(e.to_string()).in_file(&dir))?;
    let in_channels = channels;
    // Gray+alpha keeps gray only; the estimators ignore alpha anyway.
    let channels = if in_channels == 2 { 1 } else { in_channels };
    let layout = Layout::packed(files.grid, width, height, channels);
    let total = layout.validate().map_err(|e| IoError::core(&dir, e))?;
    let decoded: Vec<Result<Image, IoError>> = files
        .paths
        .par_iter()
        .map(|p| pngio::read_limited(p, limits.max_view_pixels))
        .collect();
    let mut images = Vec::with_capacity(decoded.len());
    for (image, (path, header)) in decoded.into_iter().zip(files.paths.iter().zip(&headers)) {
        let image = image?;
        if (image.width, image.height, image.channels, image.bit_depth())
            != (
                header.width,
                header.height,
                header.channels,
                header.bit_depth,
            )
        {
            return Err(
                IoError::format("changed while it was being read: try again").in_file(path),
            );
        }
        images.push(image);
    }
    let views = match depth {
        8 => {
            let mut out = Vec::with_capacity(total);
            for image in &images {
                if let Samples::Eight(s) = &image.samples {
                    if in_channels == 2 {
                        out.extend(s.iter().step_by(2));
                    } else {
                        out.extend_from_slice(s);
                    }
                }
            }
            Views::U8(out)
        }
        _ => {
            let mut out = Vec::with_capacity(total);
            let step = if in_channels == 2 { 2 } else { 1 };
            for image in &images {
                if let Samples::Sixteen(s) = &image.samples {
                    out.extend(s.iter().step_by(step).map(|&v| f32::from(v) / 65535.0));
                }
            }
            Views::F32(out)
        }
    };
    Ok(Scene {
        files,
        layout,
        views,
    })
}
