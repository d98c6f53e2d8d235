//! Nested structures: one class drawn inside another, as contouring tools draw them (the
//! endocardium inside the epicardium, a GTV inside its organ, GTV ⊂ CTV ⊂ PTV).
//!
//! Eq. 11 labels a point by the class of the most negative field, so two classes whose regions
//! overlap by design cannot both keep their region: deep inside the inner structure the outer's
//! signed distance is the more negative, and the inner loses its own inside. A sequence with
//! nesting is therefore trained on disjoint regions, the outer as outer minus inner (the wall and
//! the cavity, as every cardiac label map has them), and the pairs are recorded in the model (by
//! label, [`to_labels`]: its run record's `nesting` key) so that outputs a user reads as whole
//! structures (volumes, RT Structure Sets) put each outer back together as the union of its own
//! region and those nested in it ([`whole_structures`]). Detection and the subtraction are
//! `dynaslice-data`'s (`nesting.rs`).

/// One class drawn inside another, by class index: `inner`'s region lies within `outer`'s,
/// and `outer` is the smallest class that holds it (its direct outer).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Nested {
    /// The class inside.
    pub inner: usize,
    /// The class around it.
    pub outer: usize,
}

/// Checks `pairs` over `classes` classes: valid and distinct indices, each class inside at most
/// one direct outer, and no class inside itself through a chain.
pub fn validate(pairs: &[Nested], classes: usize) -> Result<(), String> {
    for (i, p) in pairs.iter().enumerate() {
        if p.inner >= classes || p.outer >= classes {
            return Err(format!(
                "nesting {}:{} names a class beyond the {classes} there are",
                p.inner, p.outer
            ));
        }
        if p.inner == p.outer {
            return Err(format!("class {} cannot be nested in itself", p.inner));
        }
        if pairs[..i].iter().any(|q| q.inner == p.inner) {
            return Err(format!(
                "class {} is nested in two classes; give it its direct outer only",
                p.inner
            ));
        }
    }
    for p in pairs {
        // Walk outwards: a chain longer than the classes is a cycle.
        let mut at = p.outer;
        for _ in 0..=classes {
            match pairs.iter().find(|q| q.inner == at) {
                Some(q) if q.outer == p.inner => {
                    return Err(format!(
                        "classes {} and {} are nested in each other",
                        p.inner, p.outer
                    ))
                }
                Some(q) => at = q.outer,
                None => break,
            }
        }
    }
    Ok(())
}

/// `pairs` by the source labels `labels` of the classes (channel order): `(inner, outer)`,
/// what a model records (its run record's `nesting = 3:7 5:3`).
pub fn to_labels(labels: &[i32], pairs: &[Nested]) -> Vec<(i32, i32)> {
    pairs
        .iter()
        .map(|p| (labels[p.inner], labels[p.outer]))
        .collect()
}

/// The pairs a model records by source label ([`to_labels`]) as class indices of a model whose
/// classes have source labels `labels` (channel order), checked ([`validate`]).
pub fn from_labels(recorded: &[(i32, i32)], labels: &[i32]) -> Result<Vec<Nested>, String> {
    let index = |label: i32| -> Result<usize, String> {
        labels
            .iter()
            .position(|&l| l == label)
            .ok_or_else(|| format!("nesting {label}: the model has no class of label {label}"))
    };
    let pairs = recorded
        .iter()
        .map(|&(inner, outer)| {
            Ok(Nested {
                inner: index(inner)?,
                outer: index(outer)?,
            })
        })
        .collect::<Result<Vec<_>, String>>()?;
    validate(&pairs, labels.len()).map_err(|e| format!("nesting: {e}"))?;
    Ok(pairs)
}

/// Per class of `classes`, the classes whose trained regions make up its whole structure: the
/// class itself, then every class nested in it, directly or through a chain (a PTV: its own
/// ring, the CTV's ring, the GTV). `pairs` must be valid ([`validate`]).
pub fn whole_structures(pairs: &[Nested], classes: usize) -> Vec<Vec<usize>> {
    (0..classes)
        .map(|k| {
            let mut members = vec![k];
            let mut i = 0;
            while i < members.len() {
                let at = members[i];
                members.extend(pairs.iter().filter(|p| p.outer == at).map(|p| p.inner));
                i += 1;
            }
            members
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairs_round_trip_by_label() {
        let classes = [7, 3, 5];
        let pairs = [Nested { inner: 1, outer: 0 }, Nested { inner: 2, outer: 1 }];
        let recorded = to_labels(&classes, &pairs);
        assert_eq!(recorded, [(3, 7), (5, 3)]);
        assert_eq!(from_labels(&recorded, &classes).unwrap(), pairs);
        assert_eq!(from_labels(&[], &[7, 3]).unwrap(), []);
        let e = from_labels(&[(3, 9)], &[7, 3]).unwrap_err();
        assert!(e.contains("no class of label 9"), "{e}");
        let e = from_labels(&[(3, 7), (7, 3)], &[7, 3]).unwrap_err();
        assert!(e.contains("nested in each other"), "{e}");
    }

    #[test]
    fn whole_structures_follow_chains() {
        // PTV 0 ⊃ CTV 1 ⊃ GTV 2; class 3 stands alone.
        let pairs = [Nested { inner: 2, outer: 1 }, Nested { inner: 1, outer: 0 }];
        assert!(validate(&pairs, 4).is_ok());
        let whole = whole_structures(&pairs, 4);
        assert_eq!(whole, vec![vec![0, 1, 2], vec![1, 2], vec![2], vec![3]]);
        let twice = [Nested { inner: 2, outer: 1 }, Nested { inner: 2, outer: 0 }];
        assert!(validate(&twice, 3).unwrap_err().contains("two classes"));
    }
}
