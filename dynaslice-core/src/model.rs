//! A loaded model: validated dimensions, world domain and zero-copy views of the weights.

use crate::class_record::{ClassInfo, ClassRecord, CLASS_RECORD_SIZE};
use crate::{Domain, Error, Layout};
use half::f16;

/// The weight section, borrowed from the model bytes without copying.
#[derive(Debug, Clone, Copy)]
pub enum Weights<'a> {
    /// Single-precision weights.
    F32(&'a [f32]),
    /// Half-precision weights (widened to f32 as they are used).
    F16(&'a [f16]),
}

impl<'a> Weights<'a> {
    /// Number of scalars.
    pub fn len(&self) -> usize {
        match self {
            Weights::F32(w) => w.len(),
            Weights::F16(w) => w.len(),
        }
    }

    /// True when there are no scalars.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Scalar `i` as f32, or `None` past the end.
    pub fn get(&self, i: usize) -> Option<f32> {
        match self {
            Weights::F32(w) => w.get(i).copied(),
            Weights::F16(w) => w.get(i).map(|h| h.to_f32()),
        }
    }

    /// Scalars `start..start + len` (clamped to the available range).
    pub fn sub(&self, start: usize, len: usize) -> Weights<'a> {
        fn clip<T>(w: &[T], start: usize, len: usize) -> &[T] {
            let s = start.min(w.len());
            let e = start.saturating_add(len).min(w.len());
            &w[s..e]
        }
        match *self {
            Weights::F32(w) => Weights::F32(clip(w, start, len)),
            Weights::F16(w) => Weights::F16(clip(w, start, len)),
        }
    }
}

/// One SIREN of a model (Eq. 1, 2, 4): its validated layout, the bound ω_t^max its first
/// layer's ω_t row is clamped to, and its weights in [`Layout`] order. A model's shape network
/// g is one; a motion model's motion network u ([`Model::motion`]) is another, with 3 outputs.
#[derive(Debug, Clone, Copy)]
pub struct Siren<'a> {
    pub(crate) layout: Layout,
    pub(crate) omega_t_max: f32,
    pub(crate) weights: Weights<'a>,
}

impl<'a> Siren<'a> {
    /// The network's dimensions (for the motion network, `num_classes()` is 3: the
    /// displacement's x, y, z in normalised coordinates).
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// Its own ω_t^max (Eq. 4), in normalised time.
    pub fn omega_t_max(&self) -> f32 {
        self.omega_t_max
    }

    /// Its weights, borrowed from the model bytes.
    pub fn weights(&self) -> Weights<'a> {
        self.weights
    }
}

/// A validated DynaSlice model borrowing its bytes (see [`Model::from_bytes`]).
///
/// Either f(x, t) = g(x_n, t_n), one SIREN g (the shape network, a version-1 file), or a
/// motion model f(x, t) = g(x_n + u(x_n, t_n), t_n) with a second SIREN u, the motion network
/// (a version-2 file; [`Model::motion`]). x_n, t_n are the normalised point and time
/// ([`Domain::normalise`]).
///
/// Immutable and `Sync`: any number of threads may query one model at once.
#[derive(Debug, Clone, Copy)]
pub struct Model<'a> {
    pub(crate) layout: Layout,
    pub(crate) domain: Domain,
    pub(crate) omega_t_max: f32,
    pub(crate) weights: Weights<'a>,
    /// The motion network u, for a motion model.
    pub(crate) motion: Option<Siren<'a>>,
    /// K validated records of [`CLASS_RECORD_SIZE`] bytes.
    pub(crate) classes: &'a [u8],
    pub(crate) metadata: &'a str,
}

impl<'a> Model<'a> {
    /// Network dimensions.
    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// K, the number of classes (output channels).
    pub fn num_classes(&self) -> usize {
        self.layout.num_classes()
    }

    /// The world ↔ normalised map.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// The temporal frequency bound ω_t^max of Eq. 4, in normalised time (t ∈ [0, 1]).
    pub fn omega_t_max(&self) -> f32 {
        self.omega_t_max
    }

    /// The shape network's weights (the whole weight section of a model without motion; the
    /// motion network's follow them, [`Model::motion`]).
    pub fn weights(&self) -> Weights<'a> {
        self.weights
    }

    /// The shape network g: [`Model::layout`], [`Model::omega_t_max`], [`Model::weights`].
    pub fn shape(&self) -> Siren<'a> {
        Siren {
            layout: self.layout,
            omega_t_max: self.omega_t_max,
            weights: self.weights,
        }
    }

    /// The motion network u of a motion model (its layout with 3 outputs, its own ω_t^max and
    /// its weights), or `None` for a model without motion.
    pub fn motion(&self) -> Option<Siren<'a>> {
        self.motion
    }

    /// True when f does not depend on t: ω_t^max is 0 for the shape network and, in a motion
    /// model, for the motion network too (every ω_t is then clamped to 0). Such a model was
    /// trained on one timestep.
    pub fn is_static(&self) -> bool {
        self.omega_t_max == 0.0 && self.motion.is_none_or(|m| m.omega_t_max == 0.0)
    }

    /// Free-form UTF-8 metadata (the trainer records its options here).
    pub fn metadata(&self) -> &'a str {
        self.metadata
    }

    /// Class `k` for `k` in `1..=K` (class 0 is the background of Eq. 11 and has no record).
    pub fn class(&self, k: u32) -> Result<ClassInfo<'a>, Error> {
        let i = (k as usize).checked_sub(1).ok_or(Error::NoSuchClass(k))?;
        let raw = self
            .classes
            .get(i * CLASS_RECORD_SIZE..(i + 1) * CLASS_RECORD_SIZE)
            .ok_or(Error::NoSuchClass(k))?;
        ClassRecord::decode(raw, k)
    }

    /// The classes in order 1..=K.
    pub fn classes(&self) -> impl Iterator<Item = ClassInfo<'a>> + '_ {
        (1..=self.num_classes() as u32).filter_map(move |k| self.class(k).ok())
    }

    /// The class a user names, as its 0-based channel: `key` is a class number in `1..=K` or a
    /// class name (exact match). A number wins over a class whose name is that number, so
    /// `"2"` always means the second class. `None` when nothing matches.
    pub fn find_class(&self, key: &str) -> Option<usize> {
        let by_number = key
            .parse::<usize>()
            .ok()
            .filter(|k| (1..=self.num_classes()).contains(k))
            .map(|k| k - 1);
        by_number.or_else(|| self.classes().position(|c| c.name == key))
    }
}
