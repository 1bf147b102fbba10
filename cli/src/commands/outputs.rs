//! The output files of a command, checked before any work: two outputs on one file, an
//! output onto a file the run reads (or the folder it reads), into a folder that does
//! not exist or takes no files are all refused with the flags concerned named. The
//! files themselves are written atomically ([`crate::io::output`]).

use std::path::{Path, PathBuf};

use super::CliError;
use crate::io::output::{self, same_file};
use crate::io::pattern::Pattern;
use crate::io::scene::{ViewFiles, CONFIG_FILE};
use crate::io::IoError;

/// One output: the flag that asked for it, the path as typed, where it lands.
#[derive(Clone, Debug)]
struct Planned {
    flag: &'static str,
    path: PathBuf,
    target: PathBuf,
}

/// The outputs of one run.
#[derive(Clone, Debug, Default)]
pub struct Outputs(Vec<Planned>);

fn same(a: &Path, b: &Path) -> bool {
    a == b || same_file(a, b)
}

impl Outputs {
    /// Resolves each `(flag, path)` given (a missing folder is refused) and refuses two
    /// outputs on one file.
    pub fn new(list: &[(&'static str, Option<&Path>)]) -> Result<Self, CliError> {
        let mut planned: Vec<Planned> = Vec::new();
        for &(flag, path) in list {
            let Some(path) = path else { continue };
            let target = output::resolve(path).map_err(|e| with_flag(flag, e))?;
            planned.push(Planned {
                flag,
                path: path.to_path_buf(),
                target,
            });
        }
        for (i, first) in planned.iter().enumerate() {
            // Several outputs may go to one device (`/dev/null`); only files clash.
            if std::fs::metadata(&first.target).is_ok_and(|m| !m.is_file() && !m.is_dir()) {
                continue;
            }
            let clashes: Vec<&Planned> = planned[i + 1..]
                .iter()
                .filter(|p| same(&p.target, &first.target))
                .collect();
            if !clashes.is_empty() {
                let mut named = vec![format!("{} {}", first.flag, first.path.display())];
                named.extend(
                    clashes
                        .iter()
                        .map(|p| format!("{} {}", p.flag, p.path.display())),
                );
                let last = named.pop().unwrap_or_default();
                return Err(CliError::Usage(format!(
                    "{} and {last} are the same file: give each output its own file",
                    named.join(", ")
                )));
            }
        }
        Ok(Outputs(planned))
    }

    /// Refuses an output onto a file of the light field `files` (a view, its
    /// `parameters.cfg`, a ground truth `gt_*` beside it), onto its folder, or onto a
    /// name in its folder that would be read as a view the next time.
    pub fn refuse_inputs(&self, files: &ViewFiles) -> Result<(), CliError> {
        let dir = &files.dir;
        let mut inputs: Vec<(PathBuf, String)> = files
            .paths
            .iter()
            .map(|p| (p.clone(), format!("a view of {}", dir.display())))
            .collect();
        let config = dir.join(CONFIG_FILE);
        if config.exists() {
            inputs.push((
                config,
                format!("the camera parameters of {}", dir.display()),
            ));
        }
        // The ground truth the benchmark ships beside the views (`gt_disp_lowres.pfm`,
        // `gt_depth_highres.pfm`, …): not read by every run, but never to be replaced.
        let mut truths: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|entries| {
                entries
                    .flatten()
                    .filter(|e| e.file_name().to_string_lossy().starts_with("gt_"))
                    .map(|e| e.path())
                    .collect()
            })
            .unwrap_or_default();
        truths.sort();
        for path in truths {
            inputs.push((path, format!("the ground truth of {}", dir.display())));
        }
        let canonical_dir = std::fs::canonicalize(dir).ok();
        let pattern = Pattern::parse(&files.pattern).ok();
        for out in &self.0 {
            let refuse = |why: String| {
                Err(CliError::Usage(format!(
                    "{} {} {why}: write the output elsewhere; nothing was written",
                    out.flag,
                    out.path.display()
                )))
            };
            if canonical_dir.as_deref() == Some(out.target.as_path()) {
                return refuse(format!("is the input folder {}", dir.display()));
            }
            for (path, what) in &inputs {
                if same(&out.target, path) {
                    return refuse(format!("would overwrite {}, {what}", path.display()));
                }
            }
            let in_input_folder = canonical_dir
                .as_deref()
                .is_some_and(|d| out.target.parent() == Some(d));
            let name = out.target.file_name().and_then(|n| n.to_str());
            if let (true, Some(name), Some(pattern)) = (in_input_folder, name, &pattern) {
                if pattern.matches(name).is_some() {
                    return refuse(format!(
                        "is named like a view of {} ({}) and would be read as one",
                        dir.display(),
                        pattern.as_str()
                    ));
                }
            }
        }
        Ok(())
    }

    /// Checks that every output can be written (its folder takes files; it is no
    /// folder; an existing file is writable), changing nothing.
    pub fn check_writable(&self) -> Result<(), CliError> {
        for out in &self.0 {
            output::check_writable(&out.path).map_err(|e| with_flag(out.flag, e))?;
        }
        Ok(())
    }
}

/// Prefixes an output error with the flag that named the file.
fn with_flag(flag: &str, e: IoError) -> CliError {
    CliError::Usage(format!("{flag}: {e}"))
}
