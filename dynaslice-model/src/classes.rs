//! Which classes a request means: the one reading of a user's class keys (`dynaslice mesh
//! --class`, the Python binding's `classes=`).

use dynaslice_core::Model;

/// The 0-based channels of class keys (numbers 1..K or names, [`Model::find_class`]), in the
/// order given without repeats, or every class when `wanted` is empty. An unknown key is an
/// error that lists the model's classes.
pub fn resolve_classes(model: &Model, wanted: &[String]) -> Result<Vec<usize>, String> {
    if wanted.is_empty() {
        return Ok((0..model.num_classes()).collect());
    }
    let mut out = Vec::new();
    for w in wanted {
        let Some(k) = model.find_class(w) else {
            let list: Vec<String> = model
                .classes()
                .enumerate()
                .map(|(i, c)| format!("{} {:?}", i + 1, c.name))
                .collect();
            return Err(format!(
                "no class {w:?}; the model's classes are {}",
                list.join(", ")
            ));
        };
        if !out.contains(&k) {
            out.push(k);
        }
    }
    Ok(out)
}
