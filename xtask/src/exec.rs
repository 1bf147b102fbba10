//! External commands: built as plain data (so plans can be inspected and tested), run
//! with their output streamed, or run quietly with the output kept for error messages.

use std::fmt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// A command line with its environment additions and working directory.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Cmd {
    pub program: String,
    pub args: Vec<String>,
    pub env: Vec<(String, String)>,
    pub dir: Option<PathBuf>,
}

impl Cmd {
    pub fn new(program: &str, args: &[&str]) -> Self {
        Cmd {
            program: program.to_string(),
            args: args.iter().map(|a| a.to_string()).collect(),
            env: Vec::new(),
            dir: None,
        }
    }

    /// `cargo` with these arguments (the cargo that runs xtask, when known).
    pub fn cargo(args: &[&str]) -> Self {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
        Cmd::new(&cargo, args)
    }

    pub fn args(mut self, args: &[&str]) -> Self {
        self.args.extend(args.iter().map(|a| a.to_string()));
        self
    }

    pub fn arg(mut self, arg: impl Into<String>) -> Self {
        self.args.push(arg.into());
        self
    }

    pub fn env(mut self, key: &str, value: &str) -> Self {
        self.env.push((key.to_string(), value.to_string()));
        self
    }

    pub fn dir(mut self, dir: &Path) -> Self {
        self.dir = Some(dir.to_path_buf());
        self
    }

    fn command(&self, root: &Path) -> Command {
        let mut command = Command::new(&self.program);
        command
            .args(&self.args)
            .current_dir(self.dir.as_deref().unwrap_or(root))
            // CI runs without a terminal on stdin: nothing may wait for an answer.
            .stdin(Stdio::null());
        for (key, value) in &self.env {
            command.env(key, value);
        }
        command
    }

    /// Prints `$ <command>`, then runs it with output streamed to ours; `Err` says how
    /// it failed.
    pub fn run(&self, root: &Path) -> Result<(), String> {
        println!("$ {self}");
        let status = self
            .command(root)
            .status()
            .map_err(|e| format!("could not start `{}`: {e}", self.program))?;
        if status.success() {
            Ok(())
        } else {
            Err(format!("`{self}` exited with {status}"))
        }
    }

    /// Runs with output captured; returns stdout, or an error with the command's output.
    pub fn output(&self, root: &Path) -> Result<String, String> {
        let output = self
            .command(root)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .output()
            .map_err(|e| format!("could not start `{}`: {e}", self.program))?;
        if output.status.success() {
            Ok(String::from_utf8_lossy(&output.stdout).into_owned())
        } else {
            Err(format!(
                "`{self}` exited with {}:\n{}{}",
                output.status,
                String::from_utf8_lossy(&output.stdout),
                String::from_utf8_lossy(&output.stderr)
            ))
        }
    }

    /// Prints `$ <command>`, runs it with stdout and stderr captured and kills it after
    /// `limit`; returns both outputs (stdout first) and whether it exited with status 0,
    /// or an error if it could not start or ran past the limit.
    pub fn output_within(&self, root: &Path, limit: Duration) -> Result<(String, bool), String> {
        println!("$ {self}");
        let mut child = self
            .command(root)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| format!("could not start `{}`: {e}", self.program))?;
        // Drain both pipes on threads, so a chatty child never blocks on a full pipe.
        let drain = |pipe: Option<Box<dyn std::io::Read + Send>>| {
            std::thread::spawn(move || {
                let mut text = Vec::new();
                if let Some(mut pipe) = pipe {
                    let _ = pipe.read_to_end(&mut text);
                }
                String::from_utf8_lossy(&text).into_owned()
            })
        };
        let stdout = drain(child.stdout.take().map(|p| Box::new(p) as _));
        let stderr = drain(child.stderr.take().map(|p| Box::new(p) as _));
        let start = Instant::now();
        let status = loop {
            match child.try_wait() {
                Ok(Some(status)) => break Some(status),
                Ok(None) if start.elapsed() < limit => {
                    std::thread::sleep(Duration::from_millis(50));
                }
                Ok(None) => {
                    let _ = child.kill();
                    let _ = child.wait();
                    break None;
                }
                Err(e) => return Err(format!("waiting for `{self}`: {e}")),
            }
        };
        let text = format!(
            "{}{}",
            stdout.join().unwrap_or_default(),
            stderr.join().unwrap_or_default()
        );
        match status {
            Some(status) => Ok((text, status.success())),
            None => Err(format!(
                "`{self}` ran past its limit of {} s and was stopped; its output:\n{text}",
                limit.as_secs()
            )),
        }
    }
}

impl fmt::Display for Cmd {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (key, value) in &self.env {
            write!(f, "{key}={value} ")?;
        }
        // Show `cargo`, not the absolute path of the cargo binary.
        let program = Path::new(&self.program)
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| self.program.clone());
        write!(f, "{program}")?;
        for arg in &self.args {
            if arg.contains(' ') {
                write!(f, " '{arg}'")?;
            } else {
                write!(f, " {arg}")?;
            }
        }
        if let Some(dir) = &self.dir {
            write!(f, "  (in {})", dir.display())?;
        }
        Ok(())
    }
}

/// Whether `program` can be started (it is on PATH or a path that exists).
pub fn available(program: &str) -> bool {
    Command::new(program)
        .arg("--version")
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Whether this process runs as root (so it may apt-get install).
pub fn is_root() -> bool {
    Cmd::new("id", &["-u"])
        .output(Path::new("/"))
        .is_ok_and(|uid| uid.trim() == "0")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_shows_env_program_and_quoted_args() {
        let cmd = Cmd::new("/usr/bin/cargo", &["build", "-p", "lfdepth"])
            .env("RUSTFLAGS", "-Dwarnings")
            .arg("a b");
        assert_eq!(
            cmd.to_string(),
            "RUSTFLAGS=-Dwarnings cargo build -p lfdepth 'a b'"
        );
    }

    #[test]
    fn failures_carry_the_command_output() {
        let err = Cmd::new("sh", &["-c", "echo oops >&2; exit 3"])
            .output(Path::new("/"))
            .unwrap_err();
        assert!(err.contains("oops") && err.contains('3'), "{err}");
        assert!(!available("lfdepth-no-such-program"));
    }

    #[test]
    fn output_within_returns_both_streams_and_stops_at_the_limit() {
        let (text, ok) = Cmd::new("sh", &["-c", "echo out; echo err >&2; exit 1"])
            .output_within(Path::new("/"), Duration::from_secs(30))
            .unwrap();
        assert_eq!(text, "out\nerr\n");
        assert!(!ok);
        let start = Instant::now();
        let err = Cmd::new("sh", &["-c", "echo started; exec sleep 30"])
            .output_within(Path::new("/"), Duration::from_millis(300))
            .unwrap_err();
        assert!(start.elapsed() < Duration::from_secs(10));
        assert!(err.contains("limit") && err.contains("started"), "{err}");
    }
}
