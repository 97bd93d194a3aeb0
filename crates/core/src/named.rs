//! Closed sets of names (scenarios, metrics, evaluation weeks, arms): every
//! value has one name, parsing anything else is an error that lists the
//! names that exist, and serde reads and writes the same name.

use serde::{Deserialize, Deserializer, Serializer};

use crate::error::CoreError;

/// A type whose values are a closed set of names.
pub trait Named: Copy + 'static {
    /// What kind of name it is (`metric`), for errors.
    const KIND: &'static str;
    /// Every value.
    fn values() -> &'static [Self];
    /// The value's name.
    fn name_of(self) -> &'static str;
    /// The names that exist, in words (`one of S1, S2, S3, S4`).
    fn expected() -> String {
        let names: Vec<&str> = Self::values().iter().map(|v| v.name_of()).collect();
        format!("one of {}", names.join(", "))
    }
}

/// The value named exactly `s`, or an error naming what exists.
pub fn parse<T: Named>(s: &str) -> Result<T, CoreError> {
    T::values()
        .iter()
        .copied()
        .find(|v| v.name_of() == s)
        .ok_or_else(|| unknown::<T>(s))
}

/// The error for a name `got` that is not one of `T`'s.
pub fn unknown<T: Named>(got: &str) -> CoreError {
    CoreError::UnknownName {
        what: T::KIND,
        got: got.to_string(),
        expected: T::expected(),
    }
}

/// Serialises a value as its name (for `#[serde(serialize_with)]` or a
/// `Serialize` impl).
pub fn serialize<T: Named, S: Serializer>(value: &T, serializer: S) -> Result<S::Ok, S::Error> {
    serializer.serialize_str(value.name_of())
}

/// Reads a value from its name; any other string is an error.
pub fn deserialize<'de, T: Named, D: Deserializer<'de>>(deserializer: D) -> Result<T, D::Error> {
    parse(&String::deserialize(deserializer)?).map_err(serde::de::Error::custom)
}

#[doc(hidden)]
pub use serde as __serde;

/// Implements [`Named`] and `Display` (the name) for a type with an
/// associated `ALL` array, from its kind and the function giving a value's
/// name. With
/// `, parse_and_serde` it also implements `FromStr` (exact names,
/// [`CoreError`] for others) and serde as the name.
#[macro_export]
macro_rules! named {
    ($ty:ty, $kind:expr, $name:expr) => {
        impl $crate::named::Named for $ty {
            const KIND: &'static str = $kind;
            fn values() -> &'static [Self] {
                &<$ty>::ALL
            }
            fn name_of(self) -> &'static str {
                $name(self)
            }
        }
        impl ::std::fmt::Display for $ty {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str($name(*self))
            }
        }
    };
    ($ty:ty, $kind:expr, $name:expr, parse_and_serde) => {
        $crate::named!($ty, $kind, $name);
        impl ::std::str::FromStr for $ty {
            type Err = $crate::CoreError;
            fn from_str(s: &str) -> Result<Self, $crate::CoreError> {
                $crate::named::parse(s)
            }
        }
        impl $crate::named::__serde::Serialize for $ty {
            fn serialize<S: $crate::named::__serde::Serializer>(
                &self,
                serializer: S,
            ) -> Result<S::Ok, S::Error> {
                $crate::named::serialize(self, serializer)
            }
        }
        impl<'de> $crate::named::__serde::Deserialize<'de> for $ty {
            fn deserialize<D: $crate::named::__serde::Deserializer<'de>>(
                deserializer: D,
            ) -> Result<Self, D::Error> {
                $crate::named::deserialize(deserializer)
            }
        }
    };
}
