//! Sequences read from a file with a bound on their length, checked element by element: a file
//! holding more elements than its field allows is refused at the first element beyond the bound,
//! before memory for the rest is taken (a file of 256 MiB of small numbers would otherwise be
//! built whole, several times its size in memory, before its lengths are checked).

use serde::de::{Deserialize, Deserializer, Error as _, MapAccess, SeqAccess, Visitor};
use std::collections::BTreeMap;
use std::fmt;
use std::marker::PhantomData;

/// What [`vec`] reads: at most `max` elements of `T`, for the field `what`.
struct Bounded<T> {
    max: usize,
    what: &'static str,
    element: PhantomData<T>,
}

impl<'de, T: Deserialize<'de>> Visitor<'de> for Bounded<T> {
    type Value = Vec<T>;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "a sequence of at most {} elements ({})",
            self.max, self.what
        )
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<T>, A::Error> {
        // The size hint is the file's word, so it only caps the first allocation.
        let mut out = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(self.max).min(4096));
        while let Some(x) = seq.next_element()? {
            if out.len() == self.max {
                return Err(A::Error::custom(format!(
                    "{}: more than the limit of {}",
                    self.what, self.max
                )));
            }
            out.push(x);
        }
        Ok(out)
    }
}

/// Reads a sequence of at most `max` elements, refusing the first element beyond them with a
/// message naming `what` and the bound.
pub(crate) fn vec<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    deserializer: D,
    max: usize,
    what: &'static str,
) -> Result<Vec<T>, D::Error> {
    deserializer.deserialize_seq(Bounded {
        max,
        what,
        element: PhantomData,
    })
}

/// What [`map`] reads: at most `max` entries, for the field `what`.
struct BoundedMap<K, V> {
    max: usize,
    what: &'static str,
    entries: PhantomData<(K, V)>,
}

impl<'de, K: Deserialize<'de> + Ord, V: Deserialize<'de>> Visitor<'de> for BoundedMap<K, V> {
    type Value = BTreeMap<K, V>;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "a map of at most {} entries ({})", self.max, self.what)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut entries: A) -> Result<BTreeMap<K, V>, A::Error> {
        let mut out = BTreeMap::new();
        while let Some((key, value)) = entries.next_entry()? {
            if out.len() == self.max {
                return Err(A::Error::custom(format!(
                    "{}: more than the limit of {}",
                    self.what, self.max
                )));
            }
            // A key given twice keeps its last value, as serde's own maps do.
            out.insert(key, value);
        }
        Ok(out)
    }
}

/// Reads a map of at most `max` entries, refusing the first entry beyond them with a message
/// naming `what` and the bound.
pub(crate) fn map<'de, D: Deserializer<'de>, K: Deserialize<'de> + Ord, V: Deserialize<'de>>(
    deserializer: D,
    max: usize,
    what: &'static str,
) -> Result<BTreeMap<K, V>, D::Error> {
    deserializer.deserialize_map(BoundedMap {
        max,
        what,
        entries: PhantomData,
    })
}
