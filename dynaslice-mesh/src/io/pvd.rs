//! ParaView collection (.pvd): the meshes of a time series, one `DataSet` per time and class
//! with its `timestep` (world time) and `part` (class number), so ParaView animates them.

use std::fmt::Write;

/// One file of a collection.
#[derive(Debug, Clone, PartialEq)]
pub struct Entry {
    /// World time of the mesh.
    pub time: f32,
    /// Part number (the class number k, 1-based).
    pub part: u32,
    /// File name relative to the .pvd.
    pub file: String,
}

/// The .pvd XML of `entries`.
pub fn encode(entries: &[Entry]) -> String {
    let mut s = String::from(
        "<?xml version=\"1.0\"?>\n\
         <VTKFile type=\"Collection\" version=\"0.1\" byte_order=\"LittleEndian\">\n  <Collection>\n",
    );
    for e in entries {
        // Writing to a String cannot fail.
        let _ = writeln!(
            s,
            "    <DataSet timestep=\"{}\" group=\"\" part=\"{}\" file=\"{}\"/>",
            e.time,
            e.part,
            xml_escape(&e.file)
        );
    }
    s.push_str("  </Collection>\n</VTKFile>\n");
    s
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('"', "&quot;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_every_file_with_its_time_and_part() {
        let xml = encode(&[
            Entry {
                time: 0.25,
                part: 2,
                file: "a&b.vtp".into(),
            },
            Entry {
                time: 1.0,
                part: 1,
                file: "c.vtp".into(),
            },
        ]);
        assert!(
            xml.contains("<DataSet timestep=\"0.25\" group=\"\" part=\"2\" file=\"a&amp;b.vtp\"/>")
        );
        assert!(xml.contains("timestep=\"1\" group=\"\" part=\"1\" file=\"c.vtp\""));
        assert!(xml.trim_end().ends_with("</VTKFile>"));
    }
}
