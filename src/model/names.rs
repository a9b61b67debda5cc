//! Enums whose every variant has one name, written once.
//!
//! [`named_enum!`](crate::named_enum) declares a unit enum with a name per
//! variant. That name is what serde reads and writes (scenario files,
//! `run.json`), what `as_str` and `Display` give (CSV columns, the terminal)
//! and what `FromStr` parses; the command line (`crate::cli`) accepts the
//! same names. The variants' doc comments are their help text.

/// A name that is not one of an enum's ([`named_enum!`](crate::named_enum)).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown value `{given}`: expected one of {}", expected.join(", "))]
pub struct UnknownName {
    /// What was given.
    pub given: String,
    /// The names there are.
    pub expected: &'static [&'static str],
}

/// Declares a unit enum whose variants are written `Variant = "name"`: it
/// derives `Debug`, `Clone`, `Copy`, `PartialEq`, `Eq`, `Hash` and serde's
/// traits (by the names), and gets `ALL`, `NAMES`, `as_str`, `help` (the
/// variant's doc comment), `FromStr` (error [`UnknownName`]) and `Display`.
/// Variants carry doc comments only; `default VARIANT` after the enum
/// implements `Default`.
#[macro_export]
macro_rules! named_enum {
    (
        $(#[$meta:meta])*
        $vis:vis enum $name:ident {
            $(
                $(#[doc = $doc:literal])*
                $variant:ident = $str:literal
            ),+ $(,)?
        }
        $(default $default:ident)?
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
        $vis enum $name {
            $(
                $(#[doc = $doc])*
                #[serde(rename = $str)]
                $variant,
            )+
        }

        impl $name {
            /// Every variant, in the order declared.
            pub const ALL: &'static [$name] = &[$($name::$variant),+];
            /// Every variant's name, in the same order.
            pub const NAMES: &'static [&'static str] = &[$($str),+];

            /// The variant's name: in files, on the terminal and on the
            /// command line.
            pub const fn as_str(self) -> &'static str {
                match self {
                    $($name::$variant => $str,)+
                }
            }

            /// The variant's doc comment, as one line of help.
            pub fn help(self) -> &'static str {
                match self {
                    $($name::$variant => concat!($($doc),*).trim_start(),)+
                }
            }
        }

        impl std::str::FromStr for $name {
            type Err = $crate::model::names::UnknownName;
            fn from_str(s: &str) -> Result<Self, Self::Err> {
                match s {
                    $($str => Ok($name::$variant),)+
                    _ => Err($crate::model::names::UnknownName {
                        given: s.to_string(),
                        expected: Self::NAMES,
                    }),
                }
            }
        }

        $(
            impl Default for $name {
                fn default() -> Self {
                    $name::$default
                }
            }
        )?

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.as_str())
            }
        }
    };
}

#[cfg(test)]
mod tests {
    crate::named_enum! {
        /// A test enum.
        enum Colour {
            /// The colour of the sea
            /// at noon.
            SeaBlue = "sea_blue",
            /// Red.
            Red = "red",
        }
        default Red
    }

    #[test]
    fn one_name_serves_serde_as_str_parsing_and_display() {
        assert_eq!(Colour::SeaBlue.as_str(), "sea_blue");
        assert_eq!(Colour::NAMES, &["sea_blue", "red"]);
        assert_eq!(Colour::ALL, &[Colour::SeaBlue, Colour::Red]);
        assert_eq!("red".parse::<Colour>(), Ok(Colour::Red));
        assert_eq!(Colour::Red.to_string(), "red");
        assert_eq!(
            serde_json::to_string(&Colour::SeaBlue).expect("serialises"),
            "\"sea_blue\""
        );
        assert_eq!(
            serde_json::from_str::<Colour>("\"red\"").expect("parses"),
            Colour::Red
        );
        assert_eq!(Colour::SeaBlue.help(), "The colour of the sea at noon.");
        assert_eq!(Colour::default(), Colour::Red);
        let e = "blue".parse::<Colour>().expect_err("not a name");
        assert_eq!(
            e.to_string(),
            "unknown value `blue`: expected one of sea_blue, red"
        );
    }
}
