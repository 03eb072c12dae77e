//! Validation of settings: every refusal names the user's field, the value given and the
//! range the drive accepts, so that a bad motor file or configuration says what to change.

use core::fmt;

/// The values a setting may take: a finite number between `min` and `max`, each bound
/// included or not.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Allowed {
    /// Lower bound.
    pub min: f32,
    /// Whether `min` itself is allowed.
    pub min_included: bool,
    /// Upper bound (may be `f32::INFINITY`: any finite value).
    pub max: f32,
    /// Whether `max` itself is allowed.
    pub max_included: bool,
    /// Where a bound comes from when it is another setting or a formula
    /// (`"above i_max_a"`), else empty.
    pub why: &'static str,
}

impl Allowed {
    /// `min ≤ v ≤ max`.
    pub const fn between(min: f32, max: f32) -> Self {
        Self {
            min,
            min_included: true,
            max,
            max_included: true,
            why: "",
        }
    }

    /// `min < v ≤ max`.
    pub const fn above_up_to(min: f32, max: f32) -> Self {
        Self {
            min_included: false,
            ..Self::between(min, max)
        }
    }

    /// `min ≤ v < max`.
    pub const fn from_below(min: f32, max: f32) -> Self {
        Self {
            max_included: false,
            ..Self::between(min, max)
        }
    }

    /// `min < v < max`.
    pub const fn strictly_between(min: f32, max: f32) -> Self {
        Self {
            min_included: false,
            max_included: false,
            ..Self::between(min, max)
        }
    }

    /// Any finite `v > 0`.
    pub const POSITIVE: Self = Self::above_up_to(0.0, f32::INFINITY);

    /// Any finite `v ≥ 0`.
    pub const NON_NEGATIVE: Self = Self::between(0.0, f32::INFINITY);

    /// Any finite `v`.
    pub const FINITE: Self = Self::between(f32::NEG_INFINITY, f32::INFINITY);

    /// The same range, with where its bounds come from.
    pub const fn because(self, why: &'static str) -> Self {
        Self { why, ..self }
    }

    /// Whether `v` is finite and inside the range.
    pub fn contains(&self, v: f32) -> bool {
        let above = if self.min_included {
            v >= self.min
        } else {
            v > self.min
        };
        let below = if self.max_included {
            v <= self.max
        } else {
            v < self.max
        };
        v.is_finite() && above && below
    }

    /// `Ok(v)` inside the range, else the error naming `field` and `v`. Out of line: a
    /// configuration checks some forty values, and each call site stays a few instructions
    /// (the board's flash).
    #[inline(never)]
    pub fn check(self, field: &'static str, v: f32) -> Result<f32, ParamError> {
        if self.contains(v) {
            Ok(v)
        } else {
            Err(ParamError {
                field,
                value: v,
                allowed: self,
            })
        }
    }
}

impl fmt::Display for Allowed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let open = if self.min_included { '[' } else { '(' };
        let close = if self.max_included { ']' } else { ')' };
        if self.min == f32::NEG_INFINITY {
            write!(f, "(-inf, ")?;
        } else {
            write!(f, "{open}{}, ", Num(self.min))?;
        }
        if self.max == f32::INFINITY {
            write!(f, "inf)")?;
        } else {
            write!(f, "{}{close}", Num(self.max))?;
        }
        if !self.why.is_empty() {
            write!(f, " ({})", self.why)?;
        }
        Ok(())
    }
}

/// Many settings checked in order, the first refusal kept: `checks.check(..)` for each, then
/// `checks.done()?`. Each check is one out-of-line call, so a configuration's forty checks
/// stay small in a board's flash.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Checks(Option<ParamError>);

impl Checks {
    /// No refusal yet.
    pub const fn new() -> Self {
        Self(None)
    }

    /// Checks `value` of `field` against `allowed`, unless an earlier check refused.
    #[inline(never)]
    pub fn check(&mut self, field: &'static str, value: f32, allowed: Allowed) {
        if self.0.is_none() {
            self.0 = allowed.check(field, value).err();
        }
    }

    /// The first refusal, if any.
    pub fn done(self) -> Result<(), ParamError> {
        self.0.map_or(Ok(()), Err)
    }
}

/// A setting the drive refuses: the field as the user names it, the value given, the range
/// allowed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamError {
    /// Name of the offending field (`"r_ohm"`, `"limits.i_trip_a"`).
    pub field: &'static str,
    /// The value given (NaN and infinities as given).
    pub value: f32,
    /// What the field may be.
    pub allowed: Allowed,
}

impl ParamError {
    /// Name of the offending field.
    pub fn field(&self) -> &'static str {
        self.field
    }
}

impl fmt::Display for ParamError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.value.is_finite() {
            write!(
                f,
                "{} = {}: allowed {}",
                self.field,
                Num(self.value),
                self.allowed
            )
        } else {
            write!(
                f,
                "{} = {}: must be a finite number in {}",
                self.field, self.value, self.allowed
            )
        }
    }
}

/// A number as an engineer writes it: plain from 0.001 to 10⁶, else in exponent form
/// (`1e-45`, not forty-four zeros).
struct Num(f32);

impl fmt::Display for Num {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || (1e-3..1e6).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}
