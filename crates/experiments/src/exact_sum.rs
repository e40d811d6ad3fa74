//! Exact summation of f64 values, so that partial sums merge in any order to the same bits.
//!
//! A study sharded over run ranges must give the summary of one run over all of them, bit for bit.
//! Floating-point addition is not associative, so a running `f64` sum cannot promise that; an exact
//! sum can. [`ExactSum`] keeps the sum as an integer multiple of 2⁻¹⁰⁷⁴ (the smallest subnormal, of
//! which every finite f64 is a multiple) in 68 limbs of 32 bits, a fixed-point accumulator over the
//! whole range of f64 (after Kulisch's long accumulator). Adding a value costs a few integer
//! additions; [`ExactSum::value`] rounds the exact total to the nearest f64 (ties to even), once.
//! Up to 2³⁰ values are added between carry normalisations, which keep every limb in range, so the
//! number of values is unbounded. Merges are bounded: a total of magnitude 2¹¹⁰² or more (about
//! 2⁷⁸ · `f64::MAX`) is refused by [`ExactSum::merge`].

use crate::ExperimentError;

/// Bits per limb.
const LIMB_BITS: u32 = 32;
/// Limbs: 2098 bits of f64 (exponents of bits from −1074 to 1023) plus 64 bits of headroom for the
/// count, rounded up to whole limbs.
const LIMBS: usize = 68;
/// Values added between carry normalisations: each adds less than 2³² to a limb, and a limb is an
/// i64 kept below 2³² after normalisation, so 2³⁰ additions stay below 2⁶³.
const NORMALISE_EVERY: u32 = 1 << 30;
/// The bound on the top limb of a normalised sum, exclusive: a total of magnitude below 2¹¹⁰²
/// (2³² · 2³²·⁶⁷ units of 2⁻¹⁰⁷⁴), which a merge keeps and a file's sum must respect. Additions
/// alone cannot reach it in fewer than 2⁷⁸ values, so a sum of a u64 count of values stays below.
const TOP_BOUND: i128 = 1 << LIMB_BITS;

/// A merge whose total would reach the accumulator's bound, and the total's sign.
struct Overflow {
    negative: bool,
}

/// The exact sum of f64 values, rounded once when read.
///
/// Non-finite values are kept aside: the total is NaN if a NaN or both infinities were added, ±∞ if
/// one infinity was, and otherwise the exact sum of the finite values rounded to the nearest f64
/// (±∞ when that overflows; an exact zero is +0).
///
/// Two sums compare equal when their exact totals and non-finite flags are equal, however they were
/// built.
#[derive(Clone)]
pub struct ExactSum {
    limbs: [i64; LIMBS],
    /// Additions since the last normalisation.
    pending: u32,
    nan: bool,
    positive_infinity: bool,
    negative_infinity: bool,
}

impl PartialEq for ExactSum {
    fn eq(&self, other: &Self) -> bool {
        let (a, b) = (self.normalised(), other.normalised());
        a.limbs == b.limbs
            && (a.nan, a.positive_infinity, a.negative_infinity)
                == (b.nan, b.positive_infinity, b.negative_infinity)
    }
}

impl Eq for ExactSum {}

impl std::fmt::Debug for ExactSum {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ExactSum({:e})", self.value())
    }
}

impl Default for ExactSum {
    fn default() -> Self {
        Self::new()
    }
}

impl ExactSum {
    /// The empty sum, 0.
    ///
    /// # Example
    /// ```
    /// use liebayes_experiments::ExactSum;
    /// let mut sum = ExactSum::new();
    /// for x in [1e16, 1.0, -1e16] {
    ///     sum.add(x);
    /// }
    /// // Floating-point addition gives 0 here; the exact sum keeps the 1.
    /// assert_eq!(1e16 + 1.0 - 1e16, 0.0);
    /// assert_eq!(sum.value(), 1.0);
    /// ```
    pub const fn new() -> Self {
        Self {
            limbs: [0; LIMBS],
            pending: 0,
            nan: false,
            positive_infinity: false,
            negative_infinity: false,
        }
    }

    /// Adds `x` exactly.
    pub fn add(&mut self, x: f64) {
        if !x.is_finite() {
            self.nan |= x.is_nan();
            self.positive_infinity |= x == f64::INFINITY;
            self.negative_infinity |= x == f64::NEG_INFINITY;
            return;
        }
        if x == 0.0 {
            return;
        }
        let bits = x.to_bits();
        let biased = (bits >> 52) & 0x7ff;
        let fraction = bits & ((1 << 52) - 1);
        // x = ± mantissa · 2^(shift − 1074): subnormals have exponent field 0 and no hidden bit.
        let (mantissa, shift) = if biased == 0 {
            (fraction, 0)
        } else {
            (fraction | (1 << 52), biased - 1)
        };
        let limb = usize::try_from(shift / u64::from(LIMB_BITS)).unwrap_or(LIMBS);
        let offset = shift % u64::from(LIMB_BITS);
        // The mantissa (53 bits) shifted by up to 31 bits spans three limbs.
        let wide = u128::from(mantissa) << offset;
        let sign = if x < 0.0 { -1 } else { 1 };
        for (j, target) in self.limbs[limb..].iter_mut().take(3).enumerate() {
            let chunk =
                i64::try_from((wide >> (LIMB_BITS as usize * j)) & 0xffff_ffff).unwrap_or_default();
            *target += sign * chunk;
        }
        self.pending += 1;
        if self.pending == NORMALISE_EVERY {
            self.normalise();
        }
    }

    /// Adds another sum exactly: the result is the same whatever the order of the additions and
    /// merges.
    ///
    /// # Errors
    /// [`ExperimentError::OutOfRange`] when the total's magnitude would reach 2¹¹⁰² (about
    /// 2⁷⁸ · `f64::MAX`, far beyond any sum of a u64 count of f64 values, and beyond what a file of a
    /// sum may hold): the accumulator cannot hold it, and `self` is then unchanged.
    pub fn merge(&mut self, other: &ExactSum) -> Result<(), ExperimentError> {
        *self = self
            .merged(other)
            .map_err(|o| ExperimentError::OutOfRange {
                what: "total of a merged exact sum",
                value: if o.negative {
                    "-2^1102 or less".to_owned()
                } else {
                    "2^1102 or more".to_owned()
                },
                range: "(-2^1102, 2^1102), about 2^78 f64::MAX either way (merge fewer or \
                        smaller sums)",
            })?;
        Ok(())
    }

    /// The exact sum of both, or where its total would reach 2¹¹⁰² in magnitude (the top limb
    /// leaving (−2³², 2³²), the range the reader accepts), its sign.
    fn merged(&self, other: &ExactSum) -> Result<ExactSum, Overflow> {
        let mut sum = self.normalised();
        let other = other.normalised();
        // Normalised, every limb but the top is in [0, 2³²): their sums and carries fit an i64,
        // and the top limbs, bounded by the accumulator's range, add without overflow in i128.
        let mut carry = 0_i64;
        for (a, b) in sum.limbs[..LIMBS - 1].iter_mut().zip(&other.limbs) {
            let total = *a + b + carry;
            carry = total >> LIMB_BITS;
            *a = total & 0xffff_ffff;
        }
        let top = i128::from(sum.limbs[LIMBS - 1])
            + i128::from(other.limbs[LIMBS - 1])
            + i128::from(carry);
        if top.abs() >= TOP_BOUND {
            return Err(Overflow { negative: top < 0 });
        }
        sum.limbs[LIMBS - 1] = i64::try_from(top).map_err(|_| Overflow { negative: top < 0 })?;
        sum.pending = 0;
        sum.nan |= other.nan;
        sum.positive_infinity |= other.positive_infinity;
        sum.negative_infinity |= other.negative_infinity;
        Ok(sum)
    }

    /// Propagates carries so that every limb but the last is in [0, 2³²); the last keeps the sign.
    fn normalise(&mut self) {
        if self.pending == 0 {
            return;
        }
        let mut carry = 0_i64;
        for limb in &mut self.limbs[..LIMBS - 1] {
            let total = *limb + carry;
            carry = total >> LIMB_BITS;
            *limb = total & 0xffff_ffff;
        }
        self.limbs[LIMBS - 1] += carry;
        self.pending = 0;
    }

    /// A copy with its carries propagated.
    fn normalised(&self) -> Self {
        let mut sum = self.clone();
        sum.pending = 1;
        sum.normalise();
        sum
    }

    /// Whether a NaN or an infinity was added (the flags that make [`value`](Self::value)
    /// non-finite whatever the finite values).
    pub(crate) fn has_non_finite(&self) -> bool {
        self.nan || self.positive_infinity || self.negative_infinity
    }

    /// The exact total rounded to the nearest f64 (ties to even); see the type for non-finite values.
    pub fn value(&self) -> f64 {
        if self.nan || (self.positive_infinity && self.negative_infinity) {
            return f64::NAN;
        }
        if self.positive_infinity {
            return f64::INFINITY;
        }
        if self.negative_infinity {
            return f64::NEG_INFINITY;
        }
        let mut sum = self.normalised();
        let negative = sum.limbs[LIMBS - 1] < 0;
        if negative {
            // The magnitude: every limb negated, then carried again.
            for limb in &mut sum.limbs {
                *limb = -*limb;
            }
            sum.pending = 1;
            sum.normalise();
        }
        let magnitude = sum.magnitude();
        if negative { -magnitude } else { magnitude }
    }

    /// The total divided by `count` (> 0): the rounded total divided by the count, or, where the
    /// total of finite values overflows f64, the total scaled by 2⁻⁶⁴ first, so that the mean of
    /// finite values is finite. Non-finite flags give the [`value`](Self::value)'s NaN or ±∞.
    pub(crate) fn mean(&self, count: u64) -> f64 {
        let n = count as f64;
        let total = self.value();
        if total.is_finite() || self.has_non_finite() {
            return total / n;
        }
        let mut scaled = self.clone();
        scaled.scale_down_64();
        let down = scaled.value();
        down / n * 2f64.powi(64)
    }

    /// Divides the exact total by 2⁶⁴ (two limbs down), rounded down to a multiple of 2⁻¹⁰⁷⁴: an
    /// error of less than 2⁻¹⁰¹⁰ before the scaling, nothing beside a total above f64's range.
    fn scale_down_64(&mut self) {
        let normalised = self.normalised();
        self.limbs = [0; LIMBS];
        self.limbs[..LIMBS - 2].copy_from_slice(&normalised.limbs[2..]);
        self.pending = 1;
    }

    /// The value of non-negative normalised limbs, rounded once.
    fn magnitude(&self) -> f64 {
        let Some(top) = self.limbs.iter().rposition(|&l| l != 0) else {
            return 0.0;
        };
        let limb = |i: usize| u128::try_from(self.limbs[i]).unwrap_or_default();
        if top < 2 {
            // Below 2^64 · 2^−1074: the integer has at most 64 bits, rounded once by the conversion;
            // the scaling by 2^−1074 is exact (a subnormal result has at most 52 bits).
            let integer = limb(0) | (limb(1) << LIMB_BITS);
            return scale(integer as f64, -1074);
        }
        // The top three limbs hold at least 65 significant bits; the bits below them only decide
        // rounding, so they enter as a sticky bit in the last place, well below f64's 53 bits.
        let sticky = u128::from(self.limbs[..top - 2].iter().any(|&l| l != 0));
        let integer = (limb(top) << (2 * LIMB_BITS)) | (limb(top - 1) << LIMB_BITS) | limb(top - 2);
        let exponent = i32::try_from((top - 2) * LIMB_BITS as usize).unwrap_or(i32::MAX) - 1074;
        scale((integer | sticky) as f64, exponent)
    }
}

/// `x · 2^e`, exact while the result is a normal number (overflow gives ∞), in steps that keep
/// every factor representable.
fn scale(mut x: f64, mut e: i32) -> f64 {
    let step = 2f64.powi(512);
    let back = 2f64.powi(-512);
    while e > 512 && x.is_finite() {
        x *= step;
        e -= 512;
    }
    while e < -512 && x != 0.0 {
        x *= back;
        e += 512;
    }
    x * 2f64.powi(e)
}

impl Extend<f64> for ExactSum {
    fn extend<I: IntoIterator<Item = f64>>(&mut self, values: I) {
        for x in values {
            self.add(x);
        }
    }
}

impl FromIterator<f64> for ExactSum {
    fn from_iter<I: IntoIterator<Item = f64>>(values: I) -> Self {
        let mut sum = Self::new();
        sum.extend(values);
        sum
    }
}

/// The serialized form of an [`ExactSum`]: its normalised limbs, lowest first, and the non-finite
/// flags.
#[derive(serde::Serialize)]
#[serde(rename = "ExactSum")]
struct ExactSumFields<'a> {
    limbs: &'a [i64],
    nan: bool,
    positive_infinity: bool,
    negative_infinity: bool,
}

/// [`ExactSumFields`] as read: the limbs read into their array, refused at the first beyond
/// [`LIMBS`], so that a file's limbs take no more memory than a sum's.
#[derive(serde::Deserialize)]
#[serde(rename = "ExactSum", deny_unknown_fields)]
struct ReadExactSum {
    #[serde(deserialize_with = "read_limbs")]
    limbs: Vec<i64>,
    nan: bool,
    positive_infinity: bool,
    negative_infinity: bool,
}

/// At most [`LIMBS`] limbs.
fn read_limbs<'de, D: serde::Deserializer<'de>>(deserializer: D) -> Result<Vec<i64>, D::Error> {
    crate::bounded::vec(deserializer, LIMBS, "an exact sum's limbs (68)")
}

impl serde::Serialize for ExactSum {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let sum = self.normalised();
        ExactSumFields {
            limbs: &sum.limbs,
            nan: sum.nan,
            positive_infinity: sum.positive_infinity,
            negative_infinity: sum.negative_infinity,
        }
        .serialize(serializer)
    }
}

impl<'de> serde::Deserialize<'de> for ExactSum {
    /// Reads normalised limbs back: 68 of them (refused at the 69th, before more is read), each
    /// but the last in [0, 2³²), the last in (−2³², 2³²): a total below 2¹¹⁰² in magnitude, the
    /// bound merges keep.
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        let fields = ReadExactSum::deserialize(deserializer)?;
        let limbs: [i64; LIMBS] = fields.limbs.try_into().map_err(|l: Vec<i64>| {
            D::Error::custom(format!("an exact sum has {LIMBS} limbs, not {}", l.len()))
        })?;
        if limbs[..LIMBS - 1]
            .iter()
            .any(|l| !(0..1 << LIMB_BITS).contains(l))
            || i128::from(limbs[LIMBS - 1]).abs() >= TOP_BOUND
        {
            return Err(D::Error::custom(
                "exact sum limbs out of range (each in [0, 2^32), the last in (-2^32, 2^32))",
            ));
        }
        Ok(Self {
            limbs,
            pending: 0,
            nan: fields.nan,
            positive_infinity: fields.positive_infinity,
            negative_infinity: fields.negative_infinity,
        })
    }
}
