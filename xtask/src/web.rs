//! `cargo xtask web`: builds the wasm package into `web/pkg/` and serves `web/` on
//! 127.0.0.1 — the way to open the page.
//!
//! The server is std-only and deliberately small: GET and HEAD of files under `web/`
//! only (no listing, no `..`, no symlink escapes), `application/wasm` for the module so
//! `WebAssembly.compileStreaming` works, `Cache-Control: no-store` so a rebuild shows at
//! once. One thread per connection, one request per connection. Every response carries
//! the COOP/COEP headers that make the page cross-origin isolated, so the page can share
//! the views with its workers in one `SharedArrayBuffer` instead of copying them (the
//! page needs nothing from other origins).

use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// Port used when none is given.
pub const DEFAULT_PORT: u16 = 8000;

/// Options of `cargo xtask web`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WebOptions {
    /// Port on 127.0.0.1 (0 = any free one).
    pub port: u16,
    /// Rebuild the package first.
    pub build: bool,
}

/// Parses `[--port N] [--no-build]`.
pub fn parse(args: &[&str]) -> Result<WebOptions, String> {
    let mut options = WebOptions {
        port: DEFAULT_PORT,
        build: true,
    };
    let mut rest = args.iter();
    while let Some(arg) = rest.next() {
        match *arg {
            "--no-build" => options.build = false,
            "--port" => {
                let value = rest.next().ok_or("--port needs a number")?;
                options.port = value
                    .parse()
                    .map_err(|_| format!("--port takes a port number (0-65535), not `{value}`"))?;
            }
            other => {
                return Err(format!(
                    "`web` takes --port N and --no-build, not `{other}`"
                ))
            }
        }
    }
    Ok(options)
}

/// `wasm-pack build wasm --target web --release --out-dir ../web/pkg`, with wasm-opt
/// when a recent enough one is there (see `install::wasm_opt`).
pub fn build(root: &Path) -> Result<(), String> {
    wasm_pack(root, "../web/pkg", &[])
}

/// `wasm-pack build wasm --target web --release --out-dir OUT_DIR` (relative to `wasm/`)
/// with `features` of lfdepth-wasm, with wasm-opt when a recent enough one is there.
pub fn wasm_pack(root: &Path, out_dir: &str, features: &[&str]) -> Result<(), String> {
    let mut cmd = Command::new("wasm-pack");
    cmd.current_dir(root).args([
        "build",
        "wasm",
        "--target",
        "web",
        "--release",
        "--out-dir",
        out_dir,
        "--mode",
        "no-install",
    ]);
    if let Err(why) = crate::install::wasm_opt(root) {
        println!("warning: building without wasm-opt (larger, slower .wasm): {why}");
        cmd.arg("--no-opt");
    }
    if !features.is_empty() {
        // wasm-pack hands what follows `--` to cargo build.
        cmd.args(["--", "--features", &features.join(",")]);
    }
    println!("$ {cmd:?}");
    let status = cmd
        .status()
        .map_err(|e| format!("cannot run wasm-pack ({e}): cargo install wasm-pack"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("wasm-pack failed ({status})"))
    }
}

/// Builds (unless told not to) and serves until interrupted.
pub fn run(root: &Path, options: &WebOptions) -> bool {
    if options.build {
        if let Err(e) = build(root) {
            eprintln!("error: {e}");
            return false;
        }
    }
    let web = root.join("web");
    if !web.join("pkg/lfdepth_wasm_bg.wasm").is_file() {
        eprintln!("error: web/pkg is missing: run `cargo xtask web` without --no-build");
        return false;
    }
    let listener = match TcpListener::bind(("127.0.0.1", options.port)) {
        Ok(l) => l,
        Err(e) => {
            eprintln!(
                "error: cannot listen on 127.0.0.1:{} ({e}): pick another with --port",
                options.port
            );
            return false;
        }
    };
    let port = listener
        .local_addr()
        .map(|a| a.port())
        .unwrap_or(options.port);
    println!(
        "web: serving {} at http://127.0.0.1:{port}/ (Ctrl-C stops)",
        web.display()
    );
    serve(listener, web);
    true
}

/// Answers connections on `listener` with files under `web`, forever.
pub fn serve(listener: TcpListener, web: PathBuf) {
    for stream in listener.incoming().flatten() {
        let web = web.clone();
        std::thread::spawn(move || {
            if let Err(e) = answer(stream, &web) {
                eprintln!("web: {e}");
            }
        });
    }
}

/// The headers that make the page cross-origin isolated (`SharedArrayBuffer` available).
pub const ISOLATION_HEADERS: &str =
    "Cross-Origin-Opener-Policy: same-origin\r\nCross-Origin-Embedder-Policy: require-corp\r\n";

/// A response: status line, content type and body.
#[derive(Debug, PartialEq, Eq)]
pub struct Response {
    pub status: &'static str,
    pub content_type: &'static str,
    pub body: Vec<u8>,
}

impl Response {
    fn text(status: &'static str, text: &str) -> Self {
        Response {
            status,
            content_type: "text/plain; charset=utf-8",
            body: text.as_bytes().to_vec(),
        }
    }
}

fn answer(mut stream: TcpStream, web: &Path) -> std::io::Result<()> {
    stream.set_read_timeout(Some(Duration::from_secs(10)))?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut request_line = String::new();
    reader.read_line(&mut request_line)?;
    // Headers are read and ignored.
    let mut header = String::new();
    while reader.read_line(&mut header)? > 2 {
        header.clear();
    }
    let (method, response) = respond(&request_line, web);
    write!(
        stream,
        "HTTP/1.1 {}\r\nContent-Type: {}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nX-Content-Type-Options: nosniff\r\n{ISOLATION_HEADERS}Connection: close\r\n\r\n",
        response.status,
        response.content_type,
        response.body.len()
    )?;
    if method != "HEAD" {
        stream.write_all(&response.body)?;
    }
    stream.flush()
}

/// The response to one request line (`GET /path HTTP/1.1`) and its method.
pub fn respond(request_line: &str, web: &Path) -> (String, Response) {
    let mut parts = request_line.split_whitespace();
    let method = parts.next().unwrap_or("").to_string();
    let target = parts.next().unwrap_or("");
    if method != "GET" && method != "HEAD" {
        return (
            method,
            Response::text("405 Method Not Allowed", "only GET and HEAD"),
        );
    }
    let Some(file) = resolve(web, target) else {
        return (method, Response::text("403 Forbidden", "outside web/"));
    };
    match std::fs::read(&file) {
        Ok(body) => (
            method,
            Response {
                status: "200 OK",
                content_type: content_type(&file),
                body,
            },
        ),
        Err(_) => (method, Response::text("404 Not Found", "not found")),
    }
}

/// The file under `web` that `target` names, or `None` when it would leave `web`
/// (`..` segments, encoded or not, backslashes, NUL, symlinks pointing out).
pub fn resolve(web: &Path, target: &str) -> Option<PathBuf> {
    let path = target.split(['?', '#']).next()?;
    let decoded = percent_decode(path)?;
    if !decoded.starts_with('/') || decoded.contains('\\') || decoded.contains('\0') {
        return None;
    }
    let mut file = web.to_path_buf();
    for segment in decoded.split('/').filter(|s| !s.is_empty()) {
        if segment == ".." || segment == "." {
            return None;
        }
        file.push(segment);
    }
    if decoded.ends_with('/') {
        file.push("index.html");
    }
    // Symlinks may not lead out of web/.
    if let (Ok(real), Ok(base)) = (file.canonicalize(), web.canonicalize()) {
        if !real.starts_with(base) {
            return None;
        }
    }
    Some(file)
}

fn percent_decode(text: &str) -> Option<String> {
    let bytes = text.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' {
            let hex = std::str::from_utf8(bytes.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// MIME type by extension; `.wasm` must be `application/wasm` for streaming compilation.
pub fn content_type(file: &Path) -> &'static str {
    match file.extension().and_then(|e| e.to_str()).unwrap_or("") {
        "html" => "text/html; charset=utf-8",
        "js" | "mjs" => "text/javascript; charset=utf-8",
        "css" => "text/css; charset=utf-8",
        "wasm" => "application/wasm",
        "json" => "application/json",
        "png" => "image/png",
        "svg" => "image/svg+xml",
        "ts" | "txt" | "md" => "text/plain; charset=utf-8",
        _ => "application/octet-stream",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small web/ tree, one per test (tests run in parallel).
    fn web_dir(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("xtask-web-{test}-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("pkg")).unwrap();
        std::fs::write(dir.join("index.html"), "<p>hi</p>").unwrap();
        std::fs::write(dir.join("pkg/m.wasm"), [0u8, 97, 115, 109]).unwrap();
        dir
    }

    #[test]
    fn options_parse() {
        assert_eq!(
            parse(&[]),
            Ok(WebOptions {
                port: DEFAULT_PORT,
                build: true
            })
        );
        assert_eq!(
            parse(&["--port", "0", "--no-build"]),
            Ok(WebOptions {
                port: 0,
                build: false
            })
        );
        assert!(parse(&["--port"]).unwrap_err().contains("number"));
        assert!(parse(&["--port", "x"]).unwrap_err().contains("`x`"));
        assert!(parse(&["--open"]).unwrap_err().contains("--open"));
    }

    #[test]
    fn paths_stay_under_web() {
        let web = web_dir("paths_stay_under_web");
        assert_eq!(resolve(&web, "/"), Some(web.join("index.html")));
        assert_eq!(
            resolve(&web, "/pkg/m.wasm?v=1"),
            Some(web.join("pkg").join("m.wasm"))
        );
        for bad in [
            "/../Cargo.toml",
            "/pkg/../../x",
            "/%2e%2e/secret",
            "/pkg/%2E%2E/%2e%2e/x",
            "/a\\..\\b",
            "relative",
            "/%zz",
            "/x%00",
        ] {
            assert_eq!(resolve(&web, bad), None, "{bad}");
        }
        std::fs::remove_dir_all(&web).unwrap();
    }

    #[test]
    fn responses_have_the_right_status_and_type() {
        let web = web_dir("responses_have_the_right_status_and_type");
        let (_, ok) = respond("GET /pkg/m.wasm HTTP/1.1\r\n", &web);
        assert_eq!((ok.status, ok.content_type), ("200 OK", "application/wasm"));
        assert_eq!(ok.body, [0, 97, 115, 109]);
        let (_, html) = respond("GET / HTTP/1.1", &web);
        assert_eq!(html.content_type, "text/html; charset=utf-8");
        assert_eq!(
            respond("GET /nope.js HTTP/1.1", &web).1.status,
            "404 Not Found"
        );
        assert_eq!(
            respond("GET /../x HTTP/1.1", &web).1.status,
            "403 Forbidden"
        );
        assert_eq!(
            respond("POST / HTTP/1.1", &web).1.status,
            "405 Method Not Allowed"
        );
        std::fs::remove_dir_all(&web).unwrap();
    }

    #[test]
    fn the_server_answers_over_tcp() {
        use std::io::Read;
        let web = web_dir("the_server_answers_over_tcp");
        let listener = TcpListener::bind(("127.0.0.1", 0)).unwrap();
        let port = listener.local_addr().unwrap().port();
        let served = web.clone();
        std::thread::spawn(move || serve(listener, served));
        let mut stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
        stream
            .write_all(b"GET /pkg/m.wasm HTTP/1.1\r\nHost: x\r\n\r\n")
            .unwrap();
        let mut reply = Vec::new();
        stream.read_to_end(&mut reply).unwrap();
        let text = String::from_utf8_lossy(&reply);
        assert!(text.starts_with("HTTP/1.1 200 OK\r\n"), "{text}");
        assert!(text.contains("Content-Type: application/wasm\r\n"));
        assert!(text.contains("Cross-Origin-Opener-Policy: same-origin\r\n"));
        assert!(text.contains("Cross-Origin-Embedder-Policy: require-corp\r\n"));
        assert!(reply.ends_with(&[0, 97, 115, 109]));
        std::fs::remove_dir_all(&web).unwrap();
    }
}
