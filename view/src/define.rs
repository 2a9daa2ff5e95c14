//! [`view!`](crate::view): a viewer message's struct and its schema from
//! one definition.

/// Defines a part of a viewer message: the struct (its fields public, in
/// this order) with a `Serialize` that writes them in this order, and its
/// schema's properties ([`crate::schema::Property`]) from the same list,
/// each field's doc comment its description and the expression after `=>`
/// the builder that makes its schema from that description. A field
/// written `name as "key"` is written under `key` (a Rust keyword).
///
/// A doc comment here is plain text, without a final period (the
/// generated tables add it); write a bracket `\[` so rustdoc reads no
/// link in it.
///
/// ```
/// use anguilla_view::schema::{check, count, real};
///
/// anguilla_view::view! {
///     /// One depth reading
///     pub struct Depth {
///         /// Depth below the surface (m, positive down)
///         depth_m: f32 => real,
///         /// Readings since start
///         readings as "count": u64 => count,
///     }
/// }
///
/// let s = Depth::object("A depth");
/// let v = serde_json::to_value(Depth { depth_m: 1.5, readings: 3 }).unwrap();
/// assert_eq!(v, serde_json::json!({ "depth_m": 1.5, "count": 3 }));
/// assert!(check(&s, &v).is_ok());
/// assert_eq!(s["properties"]["depth_m"]["description"], "Depth below the surface (m, positive down)");
/// assert!(check(&s, &serde_json::json!({ "depth_m": 1.5 })).is_err()); // required
/// ```
#[macro_export]
macro_rules! view {
    (
        $(#[doc = $doc:literal])*
        pub struct $name:ident {
            $(
                $(#[doc = $fdoc:literal])*
                $field:ident $(as $key:literal)? : $ty:ty => $schema:expr
            ),* $(,)?
        }
    ) => {
        $(#[doc = $doc])*
        #[derive(Debug, Clone, PartialEq)]
        pub struct $name {
            $( $(#[doc = $fdoc])* pub $field: $ty, )*
        }

        impl $name {
            /// The schema's properties, in the order written, each field's
            /// doc comment its description.
            pub fn properties() -> ::std::vec::Vec<$crate::schema::Property> {
                ::std::vec![$((
                    $crate::define::key(stringify!($field), [$($key)?]),
                    ($schema)(&$crate::define::description(&[$($fdoc),*])),
                )),*]
            }

            /// The struct's doc comment, as the schema's text.
            pub fn description() -> ::std::string::String {
                $crate::define::description(&[$($doc),*])
            }

            /// Its schema as a closed object inside a message, described by
            /// `description`.
            pub fn object(description: &str) -> ::serde_json::Value {
                $crate::schema::object(description, Self::properties())
            }

            /// Its schema as a closed object of the named type `title`
            /// (e.g. `foxglove.Vector3`), described by `description`.
            pub fn typed(title: &str, description: &str) -> ::serde_json::Value {
                $crate::schema::typed_object(title, description, Self::properties())
            }
        }

        impl ::serde::Serialize for $name {
            fn serialize<S: ::serde::Serializer>(&self, s: S) -> ::std::result::Result<S::Ok, S::Error> {
                use ::serde::ser::SerializeStruct as _;
                let fields = [$(stringify!($field)),*].len();
                let mut st = s.serialize_struct(stringify!($name), fields)?;
                $( st.serialize_field($crate::define::key(stringify!($field), [$($key)?]), &self.$field)?; )*
                st.end()
            }
        }
    };
}

/// A field's key: its name, or the one it is written under.
#[doc(hidden)]
pub fn key<const N: usize>(field: &'static str, rename: [&'static str; N]) -> &'static str {
    rename.first().copied().unwrap_or(field)
}

/// A doc comment's lines as one line of text (escaped brackets plain).
#[doc(hidden)]
pub fn description(lines: &[&str]) -> String {
    let words: Vec<&str> = lines
        .iter()
        .map(|l| l.trim())
        .filter(|l| !l.is_empty())
        .collect();
    words.join(" ").replace("\\[", "[").replace("\\]", "]")
}
