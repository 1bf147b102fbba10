//! Loading a light field from a folder of views.
//!
//! Views are PNG, JPEG or TIFF files ([`super::formats`]; `.png`, `.jpg`/`.jpeg`,
//! `.tif`/`.tiff`, the container told by the file's first bytes), found by file name:
//! - `input_CamNNN.png` (the HCI benchmark; any of the extensions): row-major index from
//!   0; the grid comes from `--grid`, else `parameters.cfg` (`num_cams_y` ×
//!   `num_cams_x`), else the smallest square holding the highest index — a gapless run
//!   of indices whose count is no square could be a linear array and needs `--grid`;
//! - `NAME_RR_CC.png`: row and column, 0- or 1-based (the smallest number found decides);
//!   the grid comes from `--grid`, `parameters.cfg` or the largest row and column (one
//!   row or column of names is a linear array, [`linear_note`]);
//! - anything else through `--pattern` (see [`super::pattern`]).
//!
//! Views of the grid may be absent ([`ViewFiles::present`]): only the views a run reads
//! must exist ([`super::needs`]), and only those are decoded ([`read_selected`]). Their
//! headers are read first: they must agree on size and sample format and fit the caps
//! of [`super::limits`], else nothing is decoded and the error names the odd view or the
//! flag that raises the cap. Views are then decoded in parallel. 8-bit images are kept
//! as `u8`, 16-bit ones become `f32` in `[0, 1]`; a gray+alpha image keeps only its gray
//! channel.

use std::path::{Path, PathBuf};

use lfdepth::{Grid, Layout};
use rayon::prelude::*;

use super::cfg::{self, SceneConfig};
use super::formats;
use super::limits::Limits;
use super::pattern::{Numbers, Pattern};
use super::png::{self as pngio, Image, Samples};
use super::IoError;

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
    /// One file per view, row-major; for an absent view, the name it would have.
    pub paths: Vec<PathBuf>,
    /// Whether each view's file exists (row-major).
    pub present: Vec<bool>,
    /// The pattern the names follow.
    pub pattern: String,
    /// `parameters.cfg`, when present.
    pub config: Option<SceneConfig>,
    /// How the grid was chosen when the names leave it open (for the user to check).
    pub grid_note: Option<String>,
}

/// The note for a linear array (one row or one column of cameras), which has one EPI
/// direction only; `None` for a grid.
pub fn linear_note(grid: Grid) -> Option<String> {
    if !grid.is_linear() {
        return None;
    }
    let (line, present, absent) = if grid.rows == 1 {
        ("row", "horizontal", "vertical")
    } else {
        ("column", "vertical", "horizontal")
    };
    Some(format!(
        "the {}x{} views are one {line} of cameras: one direction ({present}) only, the {absent} EPIs are absent; the estimate rests on the {present} parallax alone (edges along the {line} are not measured by the EPIs)",
        grid.rows, grid.cols
    ))
}

impl ViewFiles {
    /// The file name of view `index` (row-major).
    pub fn name(&self, index: usize) -> String {
        self.paths
            .get(index)
            .and_then(|p| p.file_name())
            .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
    }

    /// Row-major indices of the absent views.
    pub fn absent(&self) -> Vec<usize> {
        (0..self.present.len())
            .filter(|&i| !self.present[i])
            .collect()
    }
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
    /// The samples; views not decoded (absent, or read by no chosen stage) are zero.
    pub views: Views,
    /// Whether each view was decoded (row-major).
    pub decoded: Vec<bool>,
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

/// The name without a view extension (`.png`, `.jpg`, `.tif`, … in any case) and that
/// extension as written, when it has one.
fn split_extension(name: &str) -> Option<(&str, &str)> {
    let (stem, ext) = name.rsplit_once('.')?;
    formats::VIEW_EXTENSIONS
        .iter()
        .any(|e| e.eq_ignore_ascii_case(ext))
        .then_some((stem, ext))
}

/// The HCI pattern with each extension found among `names` (`input_Cam{index:03}.EXT`).
fn hci_patterns(names: &[String]) -> Vec<String> {
    let mut found: Vec<String> = Vec::new();
    for name in names {
        let Some((stem, ext)) = split_extension(name) else {
            continue;
        };
        let digits = stem.strip_prefix("input_Cam");
        if digits.is_some_and(|d| d.len() == 3 && d.bytes().all(|b| b.is_ascii_digit())) {
            let pattern = format!("input_Cam{{index:03}}.{ext}");
            if !found.contains(&pattern) {
                found.push(pattern);
            }
        }
    }
    found
}

/// `NAME_RR_CC.EXT` names among `names`: each distinct `(NAME, EXT)`.
fn row_col_prefixes(names: &[String]) -> Vec<(String, String)> {
    let mut prefixes: Vec<(String, String)> = Vec::new();
    for name in names {
        let Some((stem, ext)) = split_extension(name) else {
            continue;
        };
        let mut parts = stem.rsplitn(3, '_');
        let (Some(col), Some(row), Some(prefix)) = (parts.next(), parts.next(), parts.next())
        else {
            continue;
        };
        let digits =
            |s: &str| !s.is_empty() && s.len() <= 9 && s.bytes().all(|b| b.is_ascii_digit());
        let key = (prefix.to_string(), ext.to_string());
        if digits(row) && digits(col) && !prefixes.contains(&key) {
            prefixes.push(key);
        }
    }
    prefixes
}

/// Guesses the naming pattern from the files present.
fn detect_pattern(dir: &Path, names: &[String]) -> Result<Pattern, IoError> {
    match hci_patterns(names).as_slice() {
        [] => {}
        [one] => return Pattern::parse(one),
        many => {
            return Err(folder_error(
                dir,
                format!(
                    "holds HCI-named views in several formats ({}): pass --pattern to choose, e.g. --pattern '{}'",
                    many.join(", "),
                    many[0]
                ),
            ))
        }
    }
    match row_col_prefixes(names).as_slice() {
        [(prefix, ext)] => {
            let escaped = prefix.replace(['{', '}'], "");
            if escaped != *prefix {
                return Err(folder_error(
                    dir,
                    format!("view names starting `{prefix}` contain braces: rename the files"),
                ));
            }
            Pattern::parse(&format!("{prefix}_{{row}}_{{col}}.{ext}"))
        }
        [] => {
            let images = names.iter().filter(|n| split_extension(n).is_some()).count();
            Err(folder_error(
                dir,
                if images == 0 {
                    "holds no PNG views (nor JPEG or TIFF ones): expected input_CamNNN.png or NAME_RR_CC.png files (.jpg, .tif alike)".into()
                } else {
                    format!(
                        "none of its {images} image files is named like a view (input_CamNNN.png or NAME_RR_CC.png): pass --pattern, e.g. --pattern 'view_{{row}}_{{col}}.png'"
                    )
                },
            ))
        }
        many => Err(folder_error(
            dir,
            format!(
                "holds views of several light fields ({}): pass --pattern to choose, e.g. --pattern '{}_{{row}}_{{col}}.{}'",
                name_list(
                    &many
                        .iter()
                        .map(|(p, e)| format!("{p}_RR_CC.{e}"))
                        .collect::<Vec<_>>()
                ),
                many[0].0,
                many[0].1
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

/// The grid of views numbered by index from `base` when neither `--grid` nor
/// `parameters.cfg` gives it: the smallest square holding the highest index. A run of
/// at most `GRID_MAX` indices with no gap could also be a linear array: when their
/// count is no square that is an error asking for `--grid`; when it is, the square
/// comes with a note saying how to ask for a row or a column instead.
fn index_grid(
    dir: &Path,
    indices: &[usize],
    base: usize,
) -> Result<(Grid, Option<String>), IoError> {
    let max = indices.iter().copied().max().unwrap_or(base);
    let count = max - base + 1;
    // A linear array of more than the largest grid side is no light field lfdepth reads.
    let gapless = indices.len() == count && count <= lfdepth::lightfield::GRID_MAX;
    let side = square_for(count);
    if gapless && side * side != count {
        return Err(folder_error(
            dir,
            format!(
                "holds {count} views numbered by index, which fill no square grid: pass --grid 1x{count} for one row of cameras, --grid {count}x1 for one column, or the grid RxC they were taken on"
            ),
        ));
    }
    let note = gapless.then(|| {
        format!(
            "{count} views numbered by index read as a {side}x{side} grid; if they are one row or column of cameras, pass --grid 1x{count} or --grid {count}x1"
        )
    });
    Ok((Grid::new(side, side), note))
}

/// Refuses a grid the estimator cannot use; a single view or a row or column of cameras
/// too short for an EPI is named as such.
fn check_grid(dir: &Path, g: Grid) -> Result<(), IoError> {
    use lfdepth::lightfield::{GRID_MAX, GRID_MIN};
    if g.is_supported() {
        return Ok(());
    }
    let what = match (g.rows, g.cols) {
        (1, 1) => Some("holds one view (a 1x1 grid)".to_string()),
        (1, n) | (n, 1) if n < GRID_MIN => Some(format!(
            "its views form one {} of {n} cameras (a {}x{} grid)",
            if g.rows == 1 { "row" } else { "column" },
            g.rows,
            g.cols
        )),
        _ => None,
    };
    match what {
        Some(what) => Err(folder_error(
            dir,
            format!(
                "{what}: depth from a light field needs at least {GRID_MIN} views along a row or column of cameras (1x{GRID_MIN} to 1x{GRID_MAX}, {GRID_MIN}x1 to {GRID_MAX}x1) or a grid of {GRID_MIN}x{GRID_MIN} to {GRID_MAX}x{GRID_MAX}; add views, or pass --grid RxC if that is not the grid"
            ),
        )),
        None => Err(IoError::core(
            dir,
            lfdepth::Error::GridSize {
                rows: g.rows,
                cols: g.cols,
            },
        )),
    }
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
    locate_names(dir, names, config, options)
}

/// [`locate`] of a folder holding the files `names` (and `config`, its
/// `parameters.cfg`): the pattern, the grid and each view's file, from the names alone.
/// `dir` only names the folder in messages and paths.
pub fn locate_names(
    dir: &Path,
    names: Vec<String>,
    config: Option<SceneConfig>,
    options: &LoadOptions,
) -> Result<ViewFiles, IoError> {
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
    let grid_note: Option<String>;
    let base: usize;
    let cfg_grid = config
        .as_ref()
        .and_then(|c| c.grid())
        .map(|(r, c)| Grid::new(r, c));
    if pattern.uses_index() {
        let indices: Vec<usize> = found.iter().map(|f| f.numbers.index.unwrap_or(0)).collect();
        let min = indices.iter().copied().min().unwrap_or(0);
        // The HCI benchmark numbers from 0 even if Cam000 were missing.
        base = if pattern.as_str().starts_with("input_Cam{index:03}.") || min == 0 {
            0
        } else {
            1
        };
        (grid, grid_note) = match options.grid.or(cfg_grid) {
            Some(g) => (g, None),
            None => index_grid(dir, &indices, base)?,
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
        grid_note = None;
        positions = rows
            .iter()
            .zip(&cols)
            .map(|(r, c)| (r - base, c - base))
            .collect();
    }
    let g = grid;
    check_grid(dir, g)?;
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
    let name = |i: usize| {
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
    };
    let paths = (0..g.len())
        .map(|i| dir.join(slots[i].map_or_else(|| name(i), |k| found[k].name.clone())))
        .collect();
    Ok(ViewFiles {
        dir: dir.to_path_buf(),
        grid,
        paths,
        present: slots.iter().map(Option::is_some).collect(),
        pattern: pattern.as_str().to_string(),
        config,
        grid_note,
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
/// names the odd views, and one view that has the common value. `paths` are the views
/// compared, `odd` indices into them.
fn odd_views_error(
    paths: &[&PathBuf],
    odd: &[usize],
    odd_value: String,
    common_value: String,
    what: &str,
) -> IoError {
    let good = (0..paths.len()).find(|i| !odd.contains(i)).unwrap_or(0);
    let name = |i: usize| {
        paths[i]
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
        paths.len() - odd.len(),
        name(good),
    ))
    .in_file(paths[odd[0]])
}

/// Decodes every view of `files`, all of which must exist (see [`read_selected`]).
pub fn read_views(files: ViewFiles, limits: &Limits) -> Result<Scene, IoError> {
    let absent = files.absent();
    if !absent.is_empty() {
        let names: Vec<String> = absent.iter().map(|&i| files.name(i)).collect();
        return Err(folder_error(
            &files.dir,
            format!(
                "{} of the {}x{} views are missing: {}",
                absent.len(),
                files.grid.rows,
                files.grid.cols,
                name_list(&names)
            ),
        ));
    }
    let wanted = vec![true; files.paths.len()];
    read_selected(files, limits, &wanted)
}

/// Headers of the views `selected` (indices into `files.paths`), read in parallel and
/// checked to agree on size and sample format: `(width, height, channels, bit depth)`.
fn common_header(
    files: &ViewFiles,
    selected: &[usize],
    limits: &Limits,
) -> Result<(Vec<pngio::Header>, pngio::Header), IoError> {
    let paths: Vec<&PathBuf> = selected.iter().map(|&i| &files.paths[i]).collect();
    let read: Vec<Result<pngio::Header, IoError>> = paths
        .par_iter()
        .map(|p| formats::read_header(p, limits.max_view_pixels))
        .collect();
    // The first failing view in grid order, whatever the threads' timing.
    let headers = read.into_iter().collect::<Result<Vec<_>, _>>()?;
    let sizes: Vec<(usize, usize)> = headers.iter().map(|h| (h.width, h.height)).collect();
    let ((width, height), odd) = odd_ones(&sizes);
    if !odd.is_empty() {
        let (w, h) = sizes[odd[0]];
        return Err(odd_views_error(
            &paths,
            &odd,
            format!("{w}x{h} pixels"),
            format!("{width}x{height}"),
            "all views must have the same size",
        ));
    }
    let formats: Vec<(usize, u8)> = headers.iter().map(|h| (h.channels, h.bit_depth)).collect();
    let ((channels, bit_depth), odd) = odd_ones(&formats);
    if !odd.is_empty() {
        let (c, d) = formats[odd[0]];
        return Err(odd_views_error(
            &paths,
            &odd,
            format!("{c} channel(s) of {d} bits"),
            format!("{channels} of {bit_depth}"),
            "save all views alike",
        ));
    }
    let common = pngio::Header {
        width,
        height,
        channels,
        bit_depth,
    };
    Ok((headers, common))
}

/// Decodes the views `wanted` accepts (row-major; each must exist) in parallel, after
/// every one of their headers was read and found to agree and to fit `limits` (nothing
/// is decoded otherwise). The other views of the packed light field stay zero: they
/// must be views no stage reads.
pub fn read_selected(files: ViewFiles, limits: &Limits, wanted: &[bool]) -> Result<Scene, IoError> {
    let dir = files.dir.clone();
    let selected: Vec<usize> = (0..files.paths.len())
        .filter(|&i| wanted.get(i) == Some(&true))
        .collect();
    if let Some(&i) = selected.iter().find(|&&i| !files.present[i]) {
        return Err(IoError::format("is missing").in_file(&files.paths[i]));
    }
    if selected.is_empty() {
        return Err(folder_error(&dir, "no view is to be read".into()));
    }
    let (headers, common) = common_header(&files, &selected, limits)?;
    let pngio::Header {
        width,
        height,
        channels: in_channels,
        bit_depth: depth,
    } = common;
    limits
        .check_light_field(files.paths.len(), width, height)
        .map_err(|e| IoError::format(e.to_string()).in_file(&dir))?;
    // Gray+alpha keeps gray only; the estimators ignore alpha anyway.
    let channels = if in_channels == 2 { 1 } else { in_channels };
    let layout = Layout::packed(files.grid, width, height, channels);
    let total = layout.validate().map_err(|e| IoError::core(&dir, e))?;
    let mut header_of: Vec<Option<pngio::Header>> = vec![None; files.paths.len()];
    for (header, &i) in headers.iter().zip(&selected) {
        header_of[i] = Some(*header);
    }
    let views = decode_into(
        &files,
        limits,
        &layout,
        total,
        &header_of,
        in_channels,
        depth,
    )?;
    let mut decoded = vec![false; files.paths.len()];
    for &i in &selected {
        decoded[i] = true;
    }
    Ok(Scene {
        files,
        layout,
        views,
        decoded,
    })
}

/// Decodes each view with a header in `header_of` (row-major) on rayon's threads,
/// straight into its place in a zeroed light field of `total` samples: 8-bit images as
/// `u8` (a PNG with the light field's channels without a buffer of its own), 16-bit
/// ones as `f32` in `[0, 1]`; gray+alpha (`in_channels` 2) keeps its gray channel.
/// Nothing is packed on one thread afterwards, and the pages of views not decoded are
/// never touched (the allocation is zeroed lazily). The first failing view in grid
/// order is the error, whatever the threads' timing.
fn decode_into(
    files: &ViewFiles,
    limits: &Limits,
    layout: &Layout,
    total: usize,
    header_of: &[Option<pngio::Header>],
    in_channels: usize,
    depth: u8,
) -> Result<Views, IoError> {
    let step = if in_channels == 2 { 2 } else { 1 };
    let max_pixels = limits.max_view_pixels;
    let decode = |i: usize, header: pngio::Header| -> Result<Image, IoError> {
        let path = &files.paths[i];
        let image = formats::read_limited(path, max_pixels)?;
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
        Ok(image)
    };
    let stride = layout.view_stride.max(1);
    match depth {
        8 => {
            let out = fill_views(total, stride, header_of, |i, header, slot: &mut [u8]| {
                if step == 1 && formats::read_eight_into(&files.paths[i], max_pixels, header, slot)?
                {
                    return Ok(());
                }
                if let Samples::Eight(s) = &decode(i, header)?.samples {
                    for (o, &v) in slot.iter_mut().zip(s.iter().step_by(step)) {
                        *o = v;
                    }
                }
                Ok(())
            })?;
            Ok(Views::U8(out))
        }
        _ => {
            let out = fill_views(total, stride, header_of, |i, header, slot: &mut [f32]| {
                if let Samples::Sixteen(s) = &decode(i, header)?.samples {
                    for (o, &v) in slot.iter_mut().zip(s.iter().step_by(step)) {
                        *o = f32::from(v) / 65535.0;
                    }
                }
                Ok(())
            })?;
            Ok(Views::F32(out))
        }
    }
}

/// A zeroed light field of `total` samples whose views (`stride` samples each, row-major)
/// with a header in `header_of` are written by `fill` in parallel, one view per task;
/// the first failing view in grid order is the error.
fn fill_views<T, F>(
    total: usize,
    stride: usize,
    header_of: &[Option<pngio::Header>],
    fill: F,
) -> Result<Vec<T>, IoError>
where
    T: Copy + Default + Send,
    F: Fn(usize, pngio::Header, &mut [T]) -> Result<(), IoError> + Sync,
{
    let mut out = vec![T::default(); total];
    let results: Vec<Result<(), IoError>> = out
        .par_chunks_mut(stride)
        .zip(header_of.par_iter())
        .enumerate()
        .with_max_len(1)
        .map(|(i, (slot, header))| match *header {
            Some(header) => fill(i, header, slot),
            None => Ok(()),
        })
        .collect();
    results.into_iter().collect::<Result<(), _>>()?;
    Ok(out)
}
