//! A report's figures as files of their own: the SVG text as drawn, or that SVG rendered as PNG
//! (resvg) or converted to vector PDF (svg2pdf) with the one embedded font, so that a figure
//! looks the same wherever it is made.

use std::sync::{Arc, OnceLock};

use resvg::tiny_skia::{Pixmap, Transform};
use resvg::usvg::{fontdb, Options, Tree};

use crate::error::{Error, Result};

/// How each figure of a report is written alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FigureFormat {
    /// The SVG text as the page holds it.
    Svg,
    /// A PNG image at [`PNG_SCALE`] times the figure's size in CSS pixels.
    Png,
    /// A one-page vector PDF, its text in the embedded font (subset), at 96 CSS pixels to the
    /// inch.
    Pdf,
}

/// Pixels of a PNG per CSS pixel of its figure: a 640 px wide figure becomes 1 280 pixels wide,
/// sharp on a slide or a high-resolution screen.
pub const PNG_SCALE: f32 = 2.0;

impl FigureFormat {
    /// The files' extension.
    pub fn extension(self) -> &'static str {
        match self {
            FigureFormat::Svg => "svg",
            FigureFormat::Png => "png",
            FigureFormat::Pdf => "pdf",
        }
    }
}

/// The parser's options: DejaVu Sans as every generic family, loaded once, and no system fonts
/// (the figures name only `sans-serif`).
fn options() -> &'static Options<'static> {
    static OPTIONS: OnceLock<Options<'static>> = OnceLock::new();
    OPTIONS.get_or_init(|| {
        let mut db = fontdb::Database::new();
        db.load_font_data(dejavu::sans::regular().to_vec());
        db.set_sans_serif_family("DejaVu Sans");
        db.set_serif_family("DejaVu Sans");
        db.set_monospace_family("DejaVu Sans");
        Options {
            fontdb: Arc::new(db),
            ..Options::default()
        }
    })
}

/// The bytes of one figure's file in `format`; `caption` names the figure in an error.
pub fn encode(svg: &str, format: FigureFormat, caption: &str) -> Result<Vec<u8>> {
    let fail = |what: String| Error::Other(format!("report: figure \"{caption}\": {what}"));
    if format == FigureFormat::Svg {
        return Ok(format!("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n{svg}\n").into_bytes());
    }
    let tree = Tree::from_str(svg, options()).map_err(|e| fail(format!("not valid SVG: {e}")))?;
    match format {
        FigureFormat::Svg => unreachable!("returned above"),
        FigureFormat::Png => {
            let size = tree
                .size()
                .to_int_size()
                .scale_by(PNG_SCALE)
                .ok_or_else(|| {
                    fail(format!("{:?} cannot be drawn at {PNG_SCALE}×", tree.size()))
                })?;
            let mut pixmap = Pixmap::new(size.width(), size.height())
                .ok_or_else(|| fail(format!("no image of {size:?}")))?;
            resvg::render(
                &tree,
                Transform::from_scale(PNG_SCALE, PNG_SCALE),
                &mut pixmap.as_mut(),
            );
            pixmap.encode_png().map_err(|e| fail(format!("PNG: {e}")))
        }
        FigureFormat::Pdf => svg2pdf::to_pdf(
            &tree,
            svg2pdf::ConversionOptions::default(),
            // A figure's size is in CSS pixels, 96 to the inch: a 560 px figure is 5.8 in
            // (420 pt) wide, its 11 px labels 8.25 pt, as a browser prints it.
            svg2pdf::PageOptions { dpi: 96.0 },
        )
        .map_err(|e| fail(format!("PDF: {e}"))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SVG: &str = r##"<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 200 40" width="200" height="40" font-family="sans-serif" font-size="13"><rect width="200" height="40" fill="#fff"/><text x="10" y="25">μ = 6.1 ± 0.3 kg/s</text></svg>"##;

    /// The text is drawn with the embedded font: the PNG has ink where the text stands and the
    /// size asked, and the PDF embeds a font program.
    #[test]
    fn figures_are_drawn_with_their_text() {
        let png = encode(SVG, FigureFormat::Png, "t").unwrap();
        let pixmap = Pixmap::decode_png(&png).unwrap();
        assert_eq!((pixmap.width(), pixmap.height()), (400, 80));
        let dark = pixmap
            .pixels()
            .iter()
            .filter(|p| p.red() < 128 && p.alpha() == 255)
            .count();
        assert!(dark > 200, "{dark} dark pixels: the text was not drawn");
        let pdf = encode(SVG, FigureFormat::Pdf, "t").unwrap();
        assert!(pdf.starts_with(b"%PDF-"));
        assert!(
            pdf.windows(9).any(|w| w == b"FontFile2"),
            "no embedded font"
        );
        let e = encode("<svg", FigureFormat::Png, "broken").unwrap_err();
        assert!(e.to_string().contains("figure \"broken\""), "{e}");
    }
}
