//! The HCI benchmark's `parameters.cfg`: INI-like `[section]` headers and
//! `key = value` lines (`#` and `;` start comments). Known keys are typed; every other
//! key is kept, in order, with its section, so a file survives a parse/write round trip.

use std::path::Path;

use super::{read_bytes, write_bytes, IoError};

/// The camera and scene parameters of one light field. Every known key is optional:
/// synthetic and third-party files carry only some of them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneConfig {
    /// `[intrinsics] focal_length_mm`.
    pub focal_length_mm: Option<f64>,
    /// `[intrinsics] image_resolution_x_px`.
    pub image_resolution_x_px: Option<usize>,
    /// `[intrinsics] image_resolution_y_px`.
    pub image_resolution_y_px: Option<usize>,
    /// `[intrinsics] sensor_size_mm` (the larger sensor side).
    pub sensor_size_mm: Option<f64>,
    /// `[intrinsics] fstop`.
    pub fstop: Option<f64>,
    /// `[extrinsics] num_cams_x`: views per grid row.
    pub num_cams_x: Option<usize>,
    /// `[extrinsics] num_cams_y`: views per grid column.
    pub num_cams_y: Option<usize>,
    /// `[extrinsics] baseline_mm`: distance between neighbouring cameras.
    pub baseline_mm: Option<f64>,
    /// `[extrinsics] focus_distance_m`: depth of zero disparity.
    pub focus_distance_m: Option<f64>,
    /// `[meta] disp_min`.
    pub disp_min: Option<f64>,
    /// `[meta] disp_max`.
    pub disp_max: Option<f64>,
    /// Every other key as `(section, key, value)`, in file order.
    pub other: Vec<(String, String, String)>,
}

/// Where a typed key lives and how to parse it.
#[derive(Clone, Copy)]
enum Kind {
    Real,
    Count,
}

const KNOWN: [(&str, &str, Kind); 11] = [
    ("intrinsics", "focal_length_mm", Kind::Real),
    ("intrinsics", "image_resolution_x_px", Kind::Count),
    ("intrinsics", "image_resolution_y_px", Kind::Count),
    ("intrinsics", "sensor_size_mm", Kind::Real),
    ("intrinsics", "fstop", Kind::Real),
    ("extrinsics", "num_cams_x", Kind::Count),
    ("extrinsics", "num_cams_y", Kind::Count),
    ("extrinsics", "baseline_mm", Kind::Real),
    ("extrinsics", "focus_distance_m", Kind::Real),
    ("meta", "disp_min", Kind::Real),
    ("meta", "disp_max", Kind::Real),
];

/// Sections written, in order.
const SECTIONS: [&str; 3] = ["intrinsics", "extrinsics", "meta"];

impl SceneConfig {
    fn real_mut(&mut self, key: &str) -> Option<&mut Option<f64>> {
        Some(match key {
            "focal_length_mm" => &mut self.focal_length_mm,
            "sensor_size_mm" => &mut self.sensor_size_mm,
            "fstop" => &mut self.fstop,
            "baseline_mm" => &mut self.baseline_mm,
            "focus_distance_m" => &mut self.focus_distance_m,
            "disp_min" => &mut self.disp_min,
            "disp_max" => &mut self.disp_max,
            _ => return None,
        })
    }

    fn count_mut(&mut self, key: &str) -> Option<&mut Option<usize>> {
        Some(match key {
            "image_resolution_x_px" => &mut self.image_resolution_x_px,
            "image_resolution_y_px" => &mut self.image_resolution_y_px,
            "num_cams_x" => &mut self.num_cams_x,
            "num_cams_y" => &mut self.num_cams_y,
            _ => return None,
        })
    }

    fn value_text(&self, key: &str) -> Option<String> {
        let real = |v: Option<f64>| v.map(|v| v.to_string());
        let count = |v: Option<usize>| v.map(|v| v.to_string());
        match key {
            "focal_length_mm" => real(self.focal_length_mm),
            "sensor_size_mm" => real(self.sensor_size_mm),
            "fstop" => real(self.fstop),
            "baseline_mm" => real(self.baseline_mm),
            "focus_distance_m" => real(self.focus_distance_m),
            "disp_min" => real(self.disp_min),
            "disp_max" => real(self.disp_max),
            "image_resolution_x_px" => count(self.image_resolution_x_px),
            "image_resolution_y_px" => count(self.image_resolution_y_px),
            "num_cams_x" => count(self.num_cams_x),
            "num_cams_y" => count(self.num_cams_y),
            _ => None,
        }
    }

    /// The view grid `(rows, cols)` when both counts are given.
    pub fn grid(&self) -> Option<(usize, usize)> {
        Some((self.num_cams_y?, self.num_cams_x?))
    }

    /// The disparity range `[disp_min, disp_max]` when both are given.
    pub fn disparity_range(&self) -> Option<(f64, f64)> {
        Some((self.disp_min?, self.disp_max?))
    }

    /// Focal length in pixels: `focal_length_mm / sensor_size_mm · max(res_x, res_y)`.
    pub fn focal_length_px(&self) -> Option<f64> {
        let res = self.image_resolution_x_px?.max(self.image_resolution_y_px?);
        Some(self.focal_length_mm? / self.sensor_size_mm? * res as f64)
    }

    /// Depth in metres of a disparity (pixels between neighbouring views), with the
    /// benchmark's formula `z = b·f·D / (d·D + b·f)` (b baseline, f focal length in
    /// pixels, D focus distance; all in mm). `None` when a parameter is missing or the
    /// point lies at or beyond infinity.
    pub fn depth_m(&self, disparity: f64) -> Option<f64> {
        let bf = self.baseline_mm? * self.focal_length_px()?;
        let focus_mm = self.focus_distance_m? * 1000.0;
        let denominator = disparity * focus_mm + bf;
        let depth_mm = bf * focus_mm / denominator;
        (denominator > 0.0 && depth_mm.is_finite()).then_some(depth_mm / 1000.0)
    }
}

fn line_error(number: usize, message: String) -> IoError {
    IoError::format(format!("line {number}: {message}"))
}

/// Parses the text of a `parameters.cfg`. A bad value is reported with its key and line.
/// Never panics.
pub fn parse(text: &str) -> Result<SceneConfig, IoError> {
    let mut config = SceneConfig::default();
    let mut section = String::new();
    let mut seen: Vec<(String, String)> = Vec::new();
    for (index, raw) in text.lines().enumerate() {
        let number = index + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with(';') {
            continue;
        }
        if let Some(rest) = line.strip_prefix('[') {
            let Some(name) = rest.strip_suffix(']') else {
                return Err(line_error(
                    number,
                    format!("section header `{line}` lacks its closing `]`"),
                ));
            };
            section = name.trim().to_string();
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            return Err(line_error(
                number,
                format!("`{line}` is neither `[section]` nor `key = value`"),
            ));
        };
        let (key, value) = (key.trim(), value.trim());
        if key.is_empty() {
            return Err(line_error(
                number,
                format!("`{line}` has no key before `=`"),
            ));
        }
        if seen.iter().any(|(s, k)| *s == section && k == key) {
            return Err(line_error(
                number,
                format!("`{key}` is given twice in [{section}]: keep one"),
            ));
        }
        seen.push((section.clone(), key.to_string()));
        let known = KNOWN.iter().find(|(_, k, _)| *k == key);
        match known {
            Some((_, _, Kind::Real)) => {
                let v: f64 = value
                    .parse()
                    .ok()
                    .filter(|v: &f64| v.is_finite())
                    .ok_or_else(|| {
                        line_error(number, format!("`{key} = {value}` is not a finite number"))
                    })?;
                if let Some(slot) = config.real_mut(key) {
                    *slot = Some(v);
                }
            }
            Some((_, _, Kind::Count)) => {
                let v: usize = value.parse().ok().filter(|&v| v > 0).ok_or_else(|| {
                    line_error(
                        number,
                        format!("`{key} = {value}` is not a positive whole number"),
                    )
                })?;
                if let Some(slot) = config.count_mut(key) {
                    *slot = Some(v);
                }
            }
            None => config
                .other
                .push((section.clone(), key.to_string(), value.to_string())),
        }
    }
    Ok(config)
}

/// Formats a configuration as `parameters.cfg` text: the known sections first (typed
/// keys, then kept keys of that section), then any other section.
pub fn write(config: &SceneConfig) -> String {
    let mut out = String::new();
    let mut sections: Vec<&str> = SECTIONS.to_vec();
    for (section, _, _) in &config.other {
        if !sections.contains(&section.as_str()) {
            sections.push(section);
        }
    }
    for section in sections {
        let mut body = String::new();
        for (s, key, _) in KNOWN.iter() {
            if *s == section {
                if let Some(value) = config.value_text(key) {
                    body.push_str(&format!("{key} = {value}\n"));
                }
            }
        }
        for (s, key, value) in &config.other {
            if s == section {
                body.push_str(&format!("{key} = {value}\n"));
            }
        }
        if body.is_empty() {
            continue;
        }
        if !out.is_empty() {
            out.push('\n');
        }
        if !section.is_empty() {
            out.push_str(&format!("[{section}]\n"));
        }
        out.push_str(&body);
    }
    out
}

/// Reads and parses a `parameters.cfg`; errors name the file.
pub fn read(path: &Path) -> Result<SceneConfig, IoError> {
    let bytes = read_bytes(path)?;
    let text =
        String::from_utf8(bytes).map_err(|_| IoError::format("is not UTF-8 text").in_file(path))?;
    parse(&text).map_err(|e| e.in_file(path))
}

/// Writes a `parameters.cfg`; errors name the file.
pub fn save(path: &Path, config: &SceneConfig) -> Result<(), IoError> {
    write_bytes(path, write(config).as_bytes())
}

#[cfg(test)]
mod tests {
    use super::*;

    const COTTON: &str = "[intrinsics]\nfocal_length_mm = 100.0\nimage_resolution_x_px = 512\n\
        image_resolution_y_px = 512\nsensor_size_mm = 35.0\nfstop = 100.0\n\n[extrinsics]\n\
        num_cams_x = 9\nnum_cams_y = 9\nbaseline_mm = 25.0\nfocus_distance_m = 4.25\n\
        center_cam_rx_rad = 1.3232444524765015\n\n[meta]\nscene = cotton\ndisp_min = -1.6\n\
        disp_max = 1.5\n";

    #[test]
    fn typed_and_kept_keys() {
        let c = parse(COTTON).unwrap();
        assert_eq!(c.grid(), Some((9, 9)));
        assert_eq!(c.disparity_range(), Some((-1.6, 1.5)));
        assert_eq!(c.other[0].1, "center_cam_rx_rad");
        assert_eq!(c.other[1], ("meta".into(), "scene".into(), "cotton".into()));
        assert_eq!(parse(&write(&c)).unwrap(), c);
    }

    #[test]
    fn hci_depth_formula() {
        let c = parse(COTTON).unwrap();
        // Zero disparity lies on the focus plane; larger disparity is nearer.
        assert!((c.depth_m(0.0).unwrap() - 4.25).abs() < 1e-12);
        assert!(c.depth_m(1.0).unwrap() < 4.25);
        // Cotton's gt: disparity 1.36 px ↔ about 3.67 m (checked against gt_depth_lowres).
        assert!((c.depth_m(1.3625).unwrap() - 3.668).abs() < 2e-3);
    }

    #[test]
    fn bad_values_name_key_and_line() {
        let e = parse("[extrinsics]\nnum_cams_x = nine\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 2") && e.contains("num_cams_x"), "{e}");
        let e = parse("[meta]\ndisp_min = nan\n").unwrap_err().to_string();
        assert!(e.contains("disp_min"), "{e}");
        assert!(parse("[meta\n").is_err());
        assert!(parse("just words\n").is_err());
        assert!(parse("a = 1\na = 2\n").is_err());
    }
}
