//! Scene loading: the shared HCI and Lytro folders, name detection, and every kind of
//! bad folder (through the library; `cli_errors.rs` checks the same through the binary).

mod common;

use lfdepth::Grid;
use lfdepth_cli::io::png;
use lfdepth_cli::io::scene::{self, LoadOptions, Views};

fn options(pattern: Option<&str>, grid: Option<Grid>) -> LoadOptions {
    LoadOptions {
        pattern: pattern.map(str::to_string),
        grid,
    }
}

#[test]
fn shared_scenes_load_with_their_grid_and_size() {
    let Some(data) = common::shared_data("shared_scenes_load_with_their_grid_and_size") else {
        return;
    };
    for (folder, width, height) in [
        ("hci/training/cotton", 512, 512),
        ("hci/stratified/backgammon", 512, 512),
        ("real/lytro-2067", 552, 383),
    ] {
        let s = scene::load(&data.join(folder), &LoadOptions::default()).unwrap();
        assert_eq!(s.layout.grid, Grid::new(9, 9), "{folder}");
        assert_eq!(
            (s.layout.width, s.layout.height),
            (width, height),
            "{folder}"
        );
        assert_eq!(s.layout.channels, 3, "{folder}");
        let Views::U8(v) = &s.views else {
            panic!("{folder}: 8-bit views expected")
        };
        assert_eq!(v.len(), 81 * width * height * 3);
        // The packed centre view is the centre file, decoded.
        let centre = png::read(&s.files.paths[40]).unwrap();
        let lumps = width * height * 3;
        assert_eq!(
            centre.samples,
            png::Samples::Eight(v[40 * lumps..41 * lumps].to_vec()),
            "{folder}"
        );
    }
    let s = scene::locate(&data.join("real/lytro-2067"), &LoadOptions::default()).unwrap();
    assert!(s.paths[0].ends_with("2067_01_01.png"));
    assert!(s.paths[80].ends_with("2067_09_09.png"));
    assert!(s.paths[9].ends_with("2067_02_01.png"), "row-major order");
    let s = scene::locate(
        &data.join("real/lytro-2067"),
        &options(Some("2067_{row:02}_{col:02}.png"), None),
    )
    .unwrap();
    assert_eq!(s.grid, Grid::new(9, 9));
    let s = scene::locate(&data.join("hci/training/cotton"), &LoadOptions::default()).unwrap();
    assert!(s.config.is_some() && s.paths[40].ends_with("input_Cam040.png"));
}

#[test]
fn zero_based_row_col_names_and_an_explicit_grid() {
    let dir = common::temp();
    common::row_col_views(dir.path(), "v", 3, 4, 0, 16);
    let s = scene::load(dir.path(), &LoadOptions::default()).unwrap();
    assert_eq!(s.layout.grid, Grid::new(3, 4));
    assert_eq!(s.layout.channels, 1);
    assert!(s.files.paths[5].ends_with("v_01_01.png"));
    let err = scene::locate(dir.path(), &options(None, Some(Grid::new(3, 3))))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("do not fit the 3x3 grid") && err.contains("v_00_03.png"),
        "{err}"
    );
}

#[test]
fn sixteen_bit_views_become_unit_floats() {
    let dir = common::temp();
    for i in 0..9 {
        let samples = (0..16 * 16)
            .map(|k| if k == 0 { 65535 } else { (k * 7 + i) as u16 })
            .collect();
        let image = png::Image {
            width: 16,
            height: 16,
            channels: 1,
            samples: png::Samples::Sixteen(samples),
        };
        png::write(&dir.path().join(format!("input_Cam{i:03}.png")), &image).unwrap();
    }
    let s = scene::load(dir.path(), &LoadOptions::default()).unwrap();
    let Views::F32(v) = &s.views else {
        panic!("f32 views expected")
    };
    assert_eq!(v[0], 1.0);
    assert_eq!(v[1], 7.0 / 65535.0);
}

#[test]
fn gray_alpha_views_keep_gray() {
    let dir = common::temp();
    for i in 0..9 {
        png::write(
            &dir.path().join(format!("input_Cam{i:03}.png")),
            &common::view(16, 16, 2, i),
        )
        .unwrap();
    }
    let s = scene::load(dir.path(), &LoadOptions::default()).unwrap();
    assert_eq!(s.layout.channels, 1);
    let Views::U8(v) = &s.views else { panic!() };
    let png::Samples::Eight(first) = common::view(16, 16, 2, 0).samples else {
        panic!()
    };
    assert_eq!(
        v[..256],
        first.iter().step_by(2).copied().collect::<Vec<_>>()[..]
    );
}

fn load_err(dir: &std::path::Path, o: LoadOptions) -> String {
    scene::load(dir, &o).unwrap_err().to_string()
}

#[test]
fn bad_folders_say_what_is_wrong() {
    // Empty.
    let dir = common::temp();
    let e = load_err(dir.path(), LoadOptions::default());
    assert!(e.contains("no PNG views"), "{e}");
    // A missing view is named.
    common::hci_views(dir.path(), 9, 16);
    std::fs::remove_file(dir.path().join("input_Cam004.png")).unwrap();
    let e = load_err(dir.path(), LoadOptions::default());
    assert!(
        e.contains("missing") && e.contains("input_Cam004.png"),
        "{e}"
    );
    // An extra view beyond the grid of parameters.cfg.
    common::hci_views(dir.path(), 10, 16);
    std::fs::write(
        dir.path().join("parameters.cfg"),
        "[extrinsics]\nnum_cams_x = 3\nnum_cams_y = 3\n",
    )
    .unwrap();
    let e = load_err(dir.path(), LoadOptions::default());
    assert!(e.contains("input_Cam009.png") && e.contains("3x3"), "{e}");
    std::fs::remove_file(dir.path().join("input_Cam009.png")).unwrap();
    assert!(scene::load(dir.path(), &LoadOptions::default()).is_ok());
    // A bad cfg value names the file, key and line.
    std::fs::write(
        dir.path().join("parameters.cfg"),
        "[extrinsics]\nnum_cams_x = three\n",
    )
    .unwrap();
    let e = load_err(dir.path(), LoadOptions::default());
    assert!(
        e.contains("parameters.cfg") && e.contains("line 2") && e.contains("num_cams_x"),
        "{e}"
    );
    std::fs::remove_file(dir.path().join("parameters.cfg")).unwrap();
    // Different sizes: both files and both sizes.
    png::write(
        &dir.path().join("input_Cam007.png"),
        &common::view(16, 17, 1, 7),
    )
    .unwrap();
    let e = load_err(dir.path(), LoadOptions::default());
    assert!(
        e.contains("input_Cam007.png")
            && e.contains("16x17")
            && e.contains("input_Cam000.png")
            && e.contains("16x16"),
        "{e}"
    );
    // Corrupt PNG.
    std::fs::write(
        dir.path().join("input_Cam007.png"),
        b"\x89PNG\r\n\x1a\nnonsense",
    )
    .unwrap();
    let e = load_err(dir.path(), LoadOptions::default());
    assert!(e.contains("input_Cam007.png") && e.contains("PNG"), "{e}");
    // Zero-sized image.
    std::fs::write(
        dir.path().join("input_Cam007.png"),
        common::png_with_header(0, 16),
    )
    .unwrap();
    let e = load_err(dir.path(), LoadOptions::default());
    assert!(e.contains("input_Cam007.png"), "{e}");
    // Views too small for the estimator.
    let dir = common::temp();
    common::hci_views(dir.path(), 9, 8);
    let e = load_err(dir.path(), LoadOptions::default());
    assert!(e.contains("8x8") && e.contains("16x16"), "{e}");
}

#[test]
fn short_rows_and_ambiguous_folders_are_refused() {
    // One row of five cameras is a linear array; of two, too short for an EPI.
    let short = common::temp();
    common::row_col_views(short.path(), "cam", 1, 2, 1, 16);
    let e = load_err(short.path(), LoadOptions::default());
    assert!(
        e.contains("1x2") && e.contains("1x3") && e.contains("3x3"),
        "{e}"
    );
    let dir = common::temp();
    common::row_col_views(dir.path(), "cam", 1, 5, 1, 16);
    let s = scene::load(dir.path(), &LoadOptions::default()).unwrap();
    assert_eq!(s.layout.grid, Grid::new(1, 5));
    common::row_col_views(dir.path(), "other", 3, 3, 1, 16);
    let e = load_err(dir.path(), LoadOptions::default());
    assert!(e.contains("--pattern"), "{e}");
    let s = scene::load(
        dir.path(),
        &options(Some("other_{row:02}_{col:02}.png"), None),
    )
    .unwrap();
    assert_eq!(s.layout.grid, Grid::new(3, 3));
    let e = load_err(dir.path(), options(Some("x_{row}.png"), None));
    assert!(e.contains("pattern"), "{e}");
    let e = load_err(&dir.path().join("absent"), LoadOptions::default());
    assert!(e.contains("absent") && e.contains("does not exist"), "{e}");
    // Files that match no view pattern.
    let dir = common::temp();
    png::write(&dir.path().join("photo.png"), &common::view(16, 16, 1, 0)).unwrap();
    let e = load_err(dir.path(), LoadOptions::default());
    assert!(e.contains("--pattern"), "{e}");
}

#[test]
fn one_based_index_pattern() {
    let dir = common::temp();
    for i in 1..=9 {
        png::write(
            &dir.path().join(format!("view{i}.png")),
            &common::view(16, 16, 3, i),
        )
        .unwrap();
    }
    let s = scene::locate(dir.path(), &options(Some("view{index}.png"), None)).unwrap();
    assert_eq!(s.grid, Grid::new(3, 3));
    assert!(s.paths[0].ends_with("view1.png") && s.paths[8].ends_with("view9.png"));
    std::fs::remove_file(dir.path().join("view5.png")).unwrap();
    let e = load_err(
        dir.path(),
        options(Some("view{index}.png"), Some(Grid::new(3, 3))),
    );
    assert!(e.contains("missing") && e.contains("view5.png"), "{e}");
}

#[test]
fn index_names_without_a_grid() {
    let dir = common::temp();
    common::hci_views(dir.path(), 81, 16);
    let files = scene::locate(dir.path(), &LoadOptions::default()).unwrap();
    // Too many for one row or column: a square, no note.
    assert_eq!((files.grid, files.grid_note), (Grid::new(9, 9), None));
    let dir = common::temp();
    common::hci_views(dir.path(), 9, 16);
    let files = scene::locate(dir.path(), &LoadOptions::default()).unwrap();
    assert_eq!(files.grid, Grid::new(3, 3));
    assert!(files.grid_note.is_some_and(|n| n.contains("--grid 1x9")));
    // A gap: a grid with views absent, not a linear array.
    std::fs::remove_file(dir.path().join("input_Cam004.png")).unwrap();
    let files = scene::locate(dir.path(), &LoadOptions::default()).unwrap();
    assert_eq!(files.absent(), vec![4]);
    assert_eq!((files.grid, files.grid_note), (Grid::new(3, 3), None));
}
