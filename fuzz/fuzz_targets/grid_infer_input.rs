//! The `grid_infer` target's input and its call, shared by the target (as a module) and
//! by `cli/tests/fuzz_regressions.rs` (through `#[path]`), which replays the target's
//! regression corpus: both decode an input alike.
//!
//! Input: UTF-8 text, one file name a line. A first line starting with `?` holds the
//! options, `;`-separated: `grid=RxC`, `pattern=P`, `cfg=RxC` (`parameters.cfg`'s
//! `num_cams_y` × `num_cams_x`); any other option is ignored.

use std::path::Path;

use lfdepth::Grid;
use lfdepth_cli::io::cfg::SceneConfig;
use lfdepth_cli::io::scene::{self, LoadOptions, ViewFiles};
use lfdepth_cli::io::IoError;

/// One decoded input: a folder's file names (sorted), the command-line options and
/// `parameters.cfg`'s grid.
pub struct Listing {
    pub names: Vec<String>,
    pub options: LoadOptions,
    pub config: Option<SceneConfig>,
}

/// `RxC` as two numbers.
fn grid(text: &str) -> Option<(usize, usize)> {
    let (r, c) = text.split_once('x')?;
    Some((r.parse().ok()?, c.parse().ok()?))
}

impl Listing {
    /// The listing `data` holds; `None` when it is not UTF-8.
    pub fn decode(data: &[u8]) -> Option<Self> {
        let text = core::str::from_utf8(data).ok()?;
        let mut lines = text.lines().peekable();
        let mut options = LoadOptions::default();
        let mut config = None;
        if let Some(first) = lines.next_if(|l| l.starts_with('?')) {
            for option in first[1..].split(';') {
                match option.split_once('=') {
                    Some(("grid", g)) => options.grid = grid(g).map(|(r, c)| Grid::new(r, c)),
                    Some(("pattern", p)) => options.pattern = Some(p.to_string()),
                    Some(("cfg", g)) => {
                        config = grid(g).map(|(r, c)| SceneConfig {
                            num_cams_y: Some(r),
                            num_cams_x: Some(c),
                            ..SceneConfig::default()
                        })
                    }
                    _ => {}
                }
            }
        }
        let mut names: Vec<String> = lines.map(String::from).collect();
        names.sort();
        Some(Listing {
            names,
            options,
            config,
        })
    }

    /// The target's call: [`scene::locate_names`] of a folder `scene` holding the names.
    pub fn locate(&self) -> Result<ViewFiles, IoError> {
        scene::locate_names(
            Path::new("scene"),
            self.names.clone(),
            self.config.clone(),
            &self.options,
        )
    }

    /// Whether an error message may quote braces: a pattern was given, or a name holds
    /// them (names and patterns are quoted as they are); otherwise braces in a message
    /// would be a Rust debug structure.
    pub fn quotes_braces(&self) -> bool {
        self.options.pattern.is_some() || self.names.iter().any(|n| n.contains(['{', '}']))
    }
}
