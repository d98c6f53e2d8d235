//! Legends laid out to fit: items in columns of equal width, as many rows or columns as the
//! space needs, so no entry is ever cut off (the figure grows instead).

use plotters::prelude::*;
use plotters::style::IntoFont;

/// Font size of legend text.
pub(crate) const FONT: u32 = 15;
/// Height of one legend row.
pub(crate) const ROW: u32 = 22;

/// One legend entry: a filled swatch and/or a line sample, then its text.
pub(crate) struct Item {
    pub label: String,
    pub fill: Option<RGBColor>,
    pub line: Option<RGBColor>,
}

/// Where the items go.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Layout {
    pub columns: u32,
    pub rows: u32,
    pub column_width: u32,
}

impl Layout {
    /// Width of the laid-out legend.
    pub fn width(&self) -> u32 {
        self.columns * self.column_width
    }

    /// Height of the laid-out legend.
    pub fn height(&self) -> u32 {
        self.rows * ROW
    }
}

/// Width of `text` in the legend font (the bundled font must be registered); a generous
/// per-character estimate if the font cannot lay it out.
pub(crate) fn text_width(text: &str, size: u32) -> u32 {
    ("sans-serif", size)
        .into_font()
        .box_size(text)
        .map(|(w, _)| w)
        .unwrap_or(size * text.chars().count() as u32)
}

/// Width of the swatch and line part before an item's text.
fn marks(items: &[Item]) -> u32 {
    let fill = items.iter().any(|i| i.fill.is_some());
    let line = items.iter().any(|i| i.line.is_some());
    4 + if fill { 18 } else { 0 } + if line { 28 } else { 0 }
}

fn column_width(items: &[Item]) -> u32 {
    let text = items
        .iter()
        .map(|i| text_width(&i.label, FONT))
        .max()
        .unwrap_or(0);
    marks(items) + text + 16
}

/// Items in rows across `width` pixels: as many columns as fit (at least one), rows as needed.
pub(crate) fn across(items: &[Item], width: u32) -> Layout {
    let column_width = column_width(items);
    let n = items.len().max(1) as u32;
    let columns = (width / column_width).clamp(1, n);
    Layout {
        columns,
        rows: n.div_ceil(columns),
        column_width,
    }
}

/// Items in columns `height` pixels high: as many rows as fit (at least one), columns as needed.
pub(crate) fn down(items: &[Item], height: u32) -> Layout {
    let column_width = column_width(items);
    let n = items.len().max(1) as u32;
    let rows = (height / ROW).clamp(1, n);
    Layout {
        columns: n.div_ceil(rows),
        rows,
        column_width,
    }
}

/// Draws `items` laid out by `layout` with the top-left corner at (x, y), filling columns first.
pub(crate) fn draw<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    (x, y): (i32, i32),
    items: &[Item],
    layout: Layout,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let fill = items.iter().any(|i| i.fill.is_some());
    for (n, item) in items.iter().enumerate() {
        let (col, row) = (n as u32 / layout.rows, n as u32 % layout.rows);
        let x0 = x + (col * layout.column_width) as i32;
        let y0 = y + (row * ROW) as i32 + 3;
        let mut cx = x0;
        if fill {
            if let Some(c) = item.fill {
                area.draw(&Rectangle::new([(cx, y0), (cx + 14, y0 + 14)], c.filled()))?;
            }
            cx += 18;
        }
        if let Some(c) = item.line {
            area.draw(&PathElement::new(
                vec![(cx, y0 + 7), (cx + 22, y0 + 7)],
                c.stroke_width(3),
            ))?;
            cx += 28;
        }
        area.draw(&Text::new(
            item.label.clone(),
            (cx + 4, y0),
            ("sans-serif", FONT),
        ))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn items(n: usize) -> Vec<Item> {
        crate::plot::register_font();
        (0..n)
            .map(|i| Item {
                label: format!("class number {i} with a long name"),
                fill: Some(BLACK),
                line: None,
            })
            .collect()
    }

    #[test]
    fn layouts_hold_every_item_within_their_bounds() {
        let many = items(41);
        let a = across(&many, 1000);
        assert!(
            a.columns * a.rows >= 41 && a.width() <= 1000 && a.columns > 1,
            "{a:?}"
        );
        let d = down(&many, 500);
        assert!(
            d.columns * d.rows >= 41 && d.height() <= 500 && d.columns > 1,
            "{d:?}"
        );
        // Too narrow for one column: one column anyway, wider than asked (the figure grows).
        let narrow = across(&many, 10);
        assert_eq!((narrow.columns, narrow.rows), (1, 41));
        assert!(text_width("abc", FONT) > 10);
    }
}
