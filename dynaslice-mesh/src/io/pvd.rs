//! ParaView collection (.pvd): the meshes of a time series, one `DataSet` per time and class
//! with its `timestep` (world time), `group` (empty: one group), `part` (class number k, the
//! same at every time, so `part` selects one class) and `name` (the class name, which ParaView's
//! collection reader shows as the block name), so ParaView animates them with named blocks.
//! Entries are listed by time, then class: ParaView builds a time's blocks in file order.

use std::fmt::Write;

/// One file of a collection.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// World time of the mesh.
    pub time: f32,
    /// Part number (the class number k, 1-based).
    pub part: u32,
    /// Block name (the class name).
    pub name: String,
    /// File name relative to the .pvd.
    pub file: String,
}

/// The .pvd XML of `entries`, sorted by time then part (stable, so equal keys keep their order).
pub fn encode(entries: &[Entry]) -> String {
    let mut sorted: Vec<&Entry> = entries.iter().collect();
    sorted.sort_by(|a, b| a.time.total_cmp(&b.time).then(a.part.cmp(&b.part)));
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n\
         <VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n",
    );
    for e in sorted {
        // Writing to a String cannot fail.
        let _ = writeln!(
            s,
            "    <DataSet timestep=\"{}\" group=\"\" part=\"{}\" name=\"{}\" file=\"{}\"/>",
            e.time,
            e.part,
            xml_escape(&e.name),
            xml_escape(&e.file)
        );
    }
    s.push_str("  </Collection>\n</VTKFile>\n");
    s
}

/// `s` as an XML attribute value: markup escaped, control characters (which attribute-value
/// normalisation would turn into spaces anyway, or which XML forbids) replaced by spaces.
fn xml_escape(s: &str) -> String {
    super::one_line(s)
        .replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_every_file_with_its_time_part_and_name_in_time_order() {
        let xml = encode(&[
            Entry {
                time: 1.0,
                part: 1,
                name: "LV".into(),
                file: "c.vtp".into(),
            },
            Entry {
                time: 0.25,
                part: 2,
                name: "a <b> & \"c\"\n".into(),
                file: "a&b.vtp".into(),
            },
        ]);
        let first = xml.find("timestep=\"0.25\"").unwrap();
        let second = xml.find("timestep=\"1\"").unwrap();
        assert!(first < second, "{xml}");
        assert!(xml.contains(
            "<DataSet timestep=\"0.25\" group=\"\" part=\"2\" \
             name=\"a &lt;b&gt; &amp; &quot;c&quot; \" file=\"a&amp;b.vtp\"/>"
        ));
        assert!(xml.contains("timestep=\"1\" group=\"\" part=\"1\" name=\"LV\" file=\"c.vtp\""));
        assert!(xml.trim_end().ends_with("</VTKFile>"));
    }
}
