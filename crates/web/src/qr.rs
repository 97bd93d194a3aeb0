//! A QR code as inline SVG: the `qrcode` crate encodes, this draws the
//! dark modules as one path (no image file, nothing fetched; the CSP
//! allows no other kind).

/// A QR code could not be made (the text is too long for any version).
#[derive(Debug, thiserror::Error)]
#[error("cannot make a QR code of this text: {0}")]
pub struct QrError(String);

/// The QR code of `text` as an `<svg>` element with `role="img"` and the
/// accessible name `label` (escaped here: this string is put into the page
/// as it is).
pub fn svg(text: &str, label: &str) -> Result<String, QrError> {
    let code = qrcode::QrCode::new(text.as_bytes()).map_err(|e| QrError(e.to_string()))?;
    let width = code.width();
    let quiet = 4;
    let size = width + 2 * quiet;
    let mut d = String::new();
    for (i, c) in code.to_colors().iter().enumerate() {
        if *c == qrcode::Color::Dark {
            let (x, y) = (i % width + quiet, i / width + quiet);
            d.push_str(&format!("M{x} {y}h1v1h-1z"));
        }
    }
    Ok(format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"qr\" role=\"img\" aria-label=\"{}\" viewBox=\"0 0 {size} {size}\" width=\"{px}\" height=\"{px}\" shape-rendering=\"crispEdges\"><rect width=\"{size}\" height=\"{size}\" fill=\"#fff\"/><path fill=\"#000\" d=\"{d}\"/></svg>",
        escape(label),
        px = size * 6,
    ))
}

/// HTML-escapes text for an attribute (minijinja's own escaping).
pub fn escape(s: &str) -> String {
    minijinja::HtmlEscape(s).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_link_becomes_an_svg_with_a_name_and_modules() {
        let s = svg("http://127.0.0.1:8080/signin/abc", "QR <code>").unwrap();
        assert!(s.starts_with("<svg "));
        assert!(s.contains("role=\"img\""));
        assert!(s.contains("aria-label=\"QR &lt;code&gt;\""));
        assert!(s.matches('z').count() > 50, "modules drawn");
    }
}
