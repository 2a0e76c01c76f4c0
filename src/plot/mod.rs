//! Pictures of a run (PNG and SVG, plotters): per-measurement errors before and after (thesis
//! Figs. 6.1, 6.3, 6.5), error histograms, the training curve, and the measured tool
//! positions coloured by error. Every picture is listed in `figures.json` in its folder
//! (file, title, caption) for `robocal report`.

pub mod charts;
pub mod figures;

use crate::error::{Error, Result};
use crate::io::write_atomic;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

pub use figures::{ErrorRun, error_figures, training_figure};

/// Picture size (px); the SVG uses the same user units.
pub const SIZE: (u32, u32) = (1100, 600);

/// The bundled font (DejaVu Sans; licence in assets/fonts): PNG text needs a font, and no
/// system font library is used.
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font, checked by the tests; a failure leaves PNG
        // text undrawable, which the first drawing call reports as an error.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// A chart that can draw itself on any plotters backend.
pub trait Chart {
    /// Draws the chart over the whole of `root`.
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<DB>;
}

/// What drawing returns.
pub type DrawResult<DB> =
    std::result::Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

fn draw_error(path: &Path, e: impl std::fmt::Display) -> Error {
    Error::Invalid(format!("{}: drawing failed: {e}", path.display()))
}

/// One picture written by a command.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize, PartialEq)]
pub struct Figure {
    /// PNG file name, relative to the folder.
    pub png: String,
    /// SVG file name, relative to the folder.
    pub svg: String,
    /// Title drawn on the picture and shown in the report.
    pub title: String,
    /// What the picture shows (data, units), for the report.
    pub caption: String,
}

/// Renders `chart` to `dir/name.png` and `dir/name.svg` (atomically) and records it in
/// `dir/figures.json`.
pub fn save(
    dir: &Path,
    name: &str,
    title: &str,
    caption: &str,
    chart: &impl Chart,
) -> Result<Figure> {
    register_font();
    crate::io::create_dir_all(dir)?;
    let (w, h) = SIZE;
    let png_path = dir.join(format!("{name}.png"));
    let mut rgb = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_error(&png_path, e))?;
        chart.draw(&root).map_err(|e| draw_error(&png_path, e))?;
        root.present().map_err(|e| draw_error(&png_path, e))?;
    }
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(&rgb, w, h, image::ColorType::Rgb8)
        .map_err(|e| draw_error(&png_path, e))?;
    write_atomic(&png_path, &png)?;

    let svg_path = dir.join(format!("{name}.svg"));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| draw_error(&svg_path, e))?;
        chart.draw(&root).map_err(|e| draw_error(&svg_path, e))?;
        root.present().map_err(|e| draw_error(&svg_path, e))?;
    }
    write_atomic(&svg_path, svg.as_bytes())?;

    let fig = Figure {
        png: format!("{name}.png"),
        svg: format!("{name}.svg"),
        title: title.to_string(),
        caption: caption.to_string(),
    };
    record(dir, &fig)?;
    Ok(fig)
}

/// The file name of a pictures folder's manifest.
pub const MANIFEST: &str = "figures.json";

/// The manifest of a folder's pictures.
pub fn manifest_path(dir: &Path) -> PathBuf {
    dir.join(MANIFEST)
}

/// Reads `dir/figures.json`; an absent file is an empty list.
pub fn read_manifest(dir: &Path) -> Result<Vec<Figure>> {
    let path = manifest_path(dir);
    let text = match crate::io::staged_bytes(&path) {
        Some(b) => String::from_utf8_lossy(&b).into_owned(),
        None if !path.exists() => return Ok(Vec::new()),
        None => String::from_utf8(crate::io::read_capped(&path, 16 << 20)?)
            .map_err(|_| Error::Invalid(format!("{}: not UTF-8 text", path.display())))?,
    };
    serde_json::from_str(crate::io::without_bom(&text))
        .map_err(|e| Error::Invalid(format!("{}: not a figure list: {e}", path.display())))
}

/// The commands that draw into a `--plot` folder, each picture named `{command}_*` (as
/// [`forget_earlier`] is called with).
pub const COMMANDS: [&str; 5] = ["case_d", "evaluate", "identify", "plan", "train"];

/// Whether a file named `name` is a picture by its extension (`.png`, `.svg`, any letter
/// case).
pub fn is_picture(name: &str) -> bool {
    let name = name.to_ascii_lowercase();
    name.ends_with(".png") || name.ends_with(".svg")
}

/// Whether a command may write a file named `name` in a `--plot` folder: a picture
/// `{command}_*.png` or `.svg` of one of [`COMMANDS`], or the list [`MANIFEST`]; in any letter
/// case, as a case-insensitive file system takes `X.PNG` for `x.png`.
pub fn may_draw(name: &str) -> bool {
    let name = name.to_ascii_lowercase();
    name == MANIFEST
        || is_picture(&name)
            && COMMANDS
                .iter()
                .any(|c| name.strip_prefix(c).is_some_and(|r| r.starts_with('_')))
}

/// Takes the pictures named `{command}_*` off the manifest of `dir`: called once before a
/// command draws its own, so that its run replaces the listing of its earlier run in the
/// folder (a run with validation rows, then one without: the report showed the first run's
/// validation pictures beside the second's). Their files stay, unlisted (the command's own
/// outputs replace them where it draws the same pictures). Returns how many were taken off.
pub fn forget_earlier(dir: &Path, command: &str) -> Result<usize> {
    let figs = read_manifest(dir)?;
    let prefix = format!("{command}_");
    let kept: Vec<Figure> = (figs.iter())
        .filter(|f| !f.png.starts_with(&prefix))
        .cloned()
        .collect();
    let gone = figs.len() - kept.len();
    if gone > 0 {
        write_manifest(dir, &kept)?;
    }
    Ok(gone)
}

/// Adds or replaces `fig` in the manifest.
fn record(dir: &Path, fig: &Figure) -> Result<()> {
    let mut figs = read_manifest(dir)?;
    match figs.iter_mut().find(|f| f.png == fig.png) {
        Some(f) => *f = fig.clone(),
        None => figs.push(fig.clone()),
    }
    write_manifest(dir, &figs)
}

/// Writes the manifest of `dir` (atomically).
fn write_manifest(dir: &Path, figs: &[Figure]) -> Result<()> {
    let mut text = serde_json::to_string_pretty(figs)
        .map_err(|e| Error::Invalid(format!("figure list: {e}")))?;
    text.push('\n');
    write_atomic(&manifest_path(dir), text.as_bytes())
}

use image::ImageEncoder;
