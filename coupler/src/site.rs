//! `coupler make-site`: the synthetic reservoir of `scenes/fjord.toml`, written as an ESRI ASCII
//! grid (`.asc`) by a formula in this file, so the example needs no download.
//!
//! A 400 m × 240 m reservoir: a flat-floored valley along x (floor at z = −40 m, 40 m wide,
//! centred at y = 120 m) between a 35° south flank (the slide's) and a 25° north flank (the
//! far shore), closed at both ends by 30° slopes; a gentle 2 m undulation along the floor. The
//! still water is at z = 0.

use clap::Args;
use shared::terrain::dem::Grid;
use std::path::PathBuf;

/// Extent of the site [m] (x, y) and its lowest point.
pub const LENGTH: f64 = 400.0;
pub const WIDTH: f64 = 240.0;
pub const FLOOR: f64 = -40.0;
/// Slope of the south (slide) flank and of the far shore [deg].
pub const SOUTH_SLOPE: f64 = 35.0;
pub const NORTH_SLOPE: f64 = 25.0;
/// Cell size of the committed grid `scenes/fjord/fjord.asc` [m].
pub const SCENE_CELL: f64 = 4.0;

/// Elevation of the site at (x, y) [m].
pub fn elevation(x: f64, y: f64) -> f64 {
    let (centre, half_floor) = (120.0, 20.0);
    let across = if y < centre - half_floor {
        (centre - half_floor - y) * SOUTH_SLOPE.to_radians().tan()
    } else if y > centre + half_floor {
        (y - centre - half_floor) * NORTH_SLOPE.to_radians().tan()
    } else {
        0.0
    };
    // The ends: 30° slopes rising from 60 m inside each end.
    let end =
        ((x - 0.5 * LENGTH).abs() - (0.5 * LENGTH - 60.0)).max(0.0) * 30f64.to_radians().tan();
    let floor = FLOOR + 2.0 * (2.0 * std::f64::consts::PI * x / 200.0).sin();
    floor + across.max(end)
}

/// The site on a grid of spacing `cell`, its cell centres from (0, 0) to (LENGTH, WIDTH).
pub fn grid(cell: f64) -> Grid {
    let n = |extent: f64| (extent / cell).round() as usize + 1;
    Grid::from_fn(n(LENGTH), n(WIDTH), 0.0, 0.0, cell, elevation)
}

#[derive(Debug, Args)]
pub struct SiteArgs {
    /// The .asc file to write.
    #[arg(long, default_value = "scenes/fjord/fjord.asc")]
    pub out: PathBuf,
    /// Grid spacing [m] (the scene's file uses 4 m).
    #[arg(long, default_value_t = SCENE_CELL)]
    pub cell: f64,
}

/// Writes the grid; the exit code.
pub fn run(args: SiteArgs) -> u8 {
    if !(args.cell.is_finite() && args.cell > 0.0 && args.cell <= 0.5 * WIDTH) {
        eprintln!(
            "coupler: error: --cell {}: give a grid spacing in metres, in (0, {}]",
            args.cell,
            0.5 * WIDTH
        );
        return 1;
    }
    let g = grid(args.cell);
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty())
        && let Err(e) = std::fs::create_dir_all(dir)
    {
        eprintln!("coupler: error: cannot create {}: {e}", dir.display());
        return 1;
    }
    match std::fs::write(&args.out, g.to_asc()) {
        Ok(()) => {
            println!(
                "wrote {} ({} × {} cells of {} m, {} triangles)",
                args.out.display(),
                g.ncols,
                g.nrows,
                args.cell,
                2 * (g.ncols - 1) * (g.nrows - 1)
            );
            0
        }
        Err(e) => {
            eprintln!("coupler: error: cannot write {}: {e}", args.out.display());
            1
        }
    }
}
