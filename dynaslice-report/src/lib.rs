//! A report as one self-contained HTML file: sections of paragraphs, key–value lists, tables
//! (with colour swatches) and PNG figures inlined as `data:` URIs, styled by an inline style
//! sheet. Nothing is fetched from a network and nothing else needs to travel with the file, so
//! it opens the same in any browser, mailed or archived. Every text is HTML-escaped.
//!
//! The page carries a short inline script that, once the page has loaded, records whether
//! every image decoded in `data-images` on `<body>` (`"ok N"` or `"failed: ALT, …"`): what a
//! headless browser's DOM dump shows a test, and harmless to a reader.

#![warn(missing_docs)]

pub mod model_report;
pub mod viewer;

pub use model_report::{assemble, assemble_with_input, Input};

use std::fmt::Write as _;

/// A whole report.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Document {
    /// The page title and top heading.
    pub title: String,
    /// A line under the title (e.g. what was reported on, when).
    pub subtitle: String,
    /// The sections, in order.
    pub sections: Vec<Section>,
}

/// One headed section.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Section {
    /// Its heading.
    pub heading: String,
    /// Its content, in order.
    pub blocks: Vec<Block>,
}

/// One piece of content.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A paragraph of text.
    Paragraph(String),
    /// Key–value pairs (a definition list).
    Facts(Vec<(String, String)>),
    /// A table.
    Table(Table),
    /// A PNG image, shown at its natural size (scaled down to the page's width).
    Image {
        /// The PNG file's bytes.
        png: Vec<u8>,
        /// Alternative text, also the caption.
        caption: String,
    },
    /// A fragment of HTML made by this crate (e.g. [`viewer::render`]), inserted as it is.
    Html(String),
}

/// A table with a header row.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    /// Column headings.
    pub header: Vec<String>,
    /// Rows of cells (as many as the header, or fewer).
    pub rows: Vec<Vec<Cell>>,
}

/// A table cell.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    /// Text (numbers right-aligned when the whole text parses as one).
    Text(String),
    /// A colour swatch followed by the colour's text (e.g. `#e6194b`).
    Swatch([u8; 3]),
}

impl From<&str> for Cell {
    fn from(s: &str) -> Cell {
        Cell::Text(s.to_string())
    }
}

impl From<String> for Cell {
    fn from(s: String) -> Cell {
        Cell::Text(s)
    }
}

/// `text` with `&`, `<`, `>`, `"` and `'` escaped, for element content and attribute values.
pub fn escape(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

const STYLE: &str = "\
body{font-family:system-ui,-apple-system,'Segoe UI',Roboto,'DejaVu Sans',sans-serif;\
margin:2em auto;max-width:1100px;padding:0 1em;color:#1b1b1b;line-height:1.45}\
h1{margin-bottom:.2em}.subtitle{color:#555;margin-top:0}\
h2{border-bottom:2px solid #ddd;padding-bottom:.2em;margin-top:2em}\
table{border-collapse:collapse;margin:1em 0;font-size:.92em;display:block;max-width:100%;\
overflow-x:auto}\
th,td{border:1px solid #ccc;padding:.25em .6em;text-align:left}\
th{background:#f2f2f2}td.num{text-align:right;font-variant-numeric:tabular-nums}\
dl{display:grid;grid-template-columns:max-content auto;gap:.2em 1.2em}dt{font-weight:600}\
dd{margin:0;word-break:break-all}\
.swatch{display:inline-block;width:1em;height:1em;border:1px solid #555;\
vertical-align:middle;margin-right:.4em}\
figure{margin:1em 0}figure img{max-width:100%;height:auto;border:1px solid #eee}\
figcaption{color:#555;font-size:.9em}";

/// Records in `<body data-images>` whether every image decoded (see the crate docs).
const SCRIPT: &str = "window.addEventListener('load',function(){\
var bad=[],imgs=document.images;\
for(var i=0;i<imgs.length;i++){if(!(imgs[i].complete&&imgs[i].naturalWidth>0))bad.push(imgs[i].alt);}\
document.body.setAttribute('data-images',bad.length?'failed: '+bad.join(', '):'ok '+imgs.length);});";

impl Document {
    /// The page as HTML5 text.
    pub fn to_html(&self) -> String {
        let mut h = String::new();
        let _ = write!(
            h,
            "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
             <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
             <title>{}</title>\n<style>{STYLE}</style>\n<script>{SCRIPT}</script>\n</head>\n\
             <body>\n<h1>{}</h1>\n<p class=\"subtitle\">{}</p>\n",
            escape(&self.title),
            escape(&self.title),
            escape(&self.subtitle)
        );
        for s in &self.sections {
            let _ = writeln!(h, "<section>\n<h2>{}</h2>", escape(&s.heading));
            for b in &s.blocks {
                block(&mut h, b);
            }
            h.push_str("</section>\n");
        }
        h.push_str("</body>\n</html>\n");
        h
    }
}

fn block(h: &mut String, b: &Block) {
    match b {
        Block::Paragraph(text) => {
            let _ = writeln!(h, "<p>{}</p>", escape(text));
        }
        Block::Facts(pairs) => {
            h.push_str("<dl>\n");
            for (k, v) in pairs {
                let _ = writeln!(h, "<dt>{}</dt><dd>{}</dd>", escape(k), escape(v));
            }
            h.push_str("</dl>\n");
        }
        Block::Table(t) => {
            h.push_str("<table>\n<thead><tr>");
            for c in &t.header {
                let _ = write!(h, "<th>{}</th>", escape(c));
            }
            h.push_str("</tr></thead>\n<tbody>\n");
            for row in &t.rows {
                h.push_str("<tr>");
                for c in row {
                    match c {
                        Cell::Text(s) if s.trim().parse::<f64>().is_ok() => {
                            let _ = write!(h, "<td class=\"num\">{}</td>", escape(s));
                        }
                        Cell::Text(s) => {
                            let _ = write!(h, "<td>{}</td>", escape(s));
                        }
                        Cell::Swatch([r, g, b]) => {
                            let hex = format!("#{r:02x}{g:02x}{b:02x}");
                            let _ = write!(
                                h,
                                "<td><span class=\"swatch\" style=\"background:{hex}\"></span>\
                                 {hex}</td>"
                            );
                        }
                    }
                }
                h.push_str("</tr>\n");
            }
            h.push_str("</tbody>\n</table>\n");
        }
        Block::Html(fragment) => h.push_str(fragment),
        Block::Image { png, caption } => {
            let _ = writeln!(
                h,
                "<figure><img src=\"data:image/png;base64,{}\" alt=\"{}\">\
                 <figcaption>{}</figcaption></figure>",
                base64::encode(png),
                escape(caption),
                escape(caption)
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes_text_and_inlines_images() {
        let doc = Document {
            title: "a <b> & \"c\"".into(),
            subtitle: "sub".into(),
            sections: vec![Section {
                heading: "H".into(),
                blocks: vec![
                    Block::Paragraph("x < y".into()),
                    Block::Facts(vec![("k".into(), "v&".into())]),
                    Block::Table(Table {
                        header: vec!["name".into(), "colour".into(), "mL".into()],
                        rows: vec![vec![
                            "<lung>".into(),
                            Cell::Swatch([230, 25, 75]),
                            "12.5".into(),
                        ]],
                    }),
                    Block::Image {
                        png: vec![0x89, b'P', b'N', b'G'],
                        caption: "fig 'one'".into(),
                    },
                ],
            }],
        };
        let html = doc.to_html();
        assert!(html.starts_with("<!DOCTYPE html>"));
        assert!(html.contains("<title>a &lt;b&gt; &amp; &quot;c&quot;</title>"));
        assert!(html.contains("<p>x &lt; y</p>"));
        assert!(html.contains("<dd>v&amp;</dd>"));
        assert!(html.contains("<td>&lt;lung&gt;</td>"));
        assert!(html.contains("background:#e6194b"));
        assert!(html.contains("<td class=\"num\">12.5</td>"));
        assert!(html.contains("src=\"data:image/png;base64,iVBORw==\" alt=\"fig &#39;one&#39;\""));
        // Nothing is fetched: no external reference of any kind.
        for needle in ["http:", "https:", "src=\"/", "href="] {
            assert!(!html.contains(needle), "{needle}");
        }
    }
}
