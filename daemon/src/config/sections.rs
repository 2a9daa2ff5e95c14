//! The sections of the file that other processes read ([`OTHER_SECTIONS`]):
//! the daemon takes them out of the top-level table unread, so that
//! [`Config`](super::Config)'s `deny_unknown_fields` refuses every other
//! unknown section as before, while toml still names the line of what is
//! wrong (a `toml::Table` parsed first and filtered would lose the spans).

use serde::de::{self, DeserializeSeed, Deserializer, MapAccess, Visitor};

/// The file's sections that other processes read, which the daemon accepts
/// without reading them: `[link]` (`anguilla link`) and `[foxglove]`
/// (`anguilla foxglove`). The root package's whole-file configuration
/// (`anguilla::config`) reads and checks them. In the order the default
/// file writes them, which is also the order the error for an unknown
/// section lists them in.
pub const OTHER_SECTIONS: [&str; 2] = ["foxglove", "link"];

/// A document's deserializer whose top-level table loses the keys of
/// [`OTHER_SECTIONS`] (their values go into `kept`, as written) before
/// the struct sees it. An unknown top-level key gets serde's unknown-field
/// message with the other sections among the expected ones.
pub(super) struct WithoutOthers<'k, D> {
    pub(super) inner: D,
    pub(super) kept: &'k mut toml::Table,
}

impl<'de, D: Deserializer<'de>> Deserializer<'de> for WithoutOthers<'_, D> {
    type Error = D::Error;

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        name: &'static str,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, D::Error> {
        self.inner.deserialize_struct(
            name,
            fields,
            TopVisitor {
                inner: visitor,
                fields,
                kept: self.kept,
            },
        )
    }

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, D::Error> {
        self.inner.deserialize_any(TopVisitor {
            inner: visitor,
            fields: &[],
            kept: self.kept,
        })
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf option unit unit_struct newtype_struct seq tuple
        tuple_struct map enum identifier ignored_any
    }
}

struct TopVisitor<'k, V> {
    inner: V,
    fields: &'static [&'static str],
    kept: &'k mut toml::Table,
}

impl<'de, V: Visitor<'de>> Visitor<'de> for TopVisitor<'_, V> {
    type Value = V::Value;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        self.inner.expecting(f)
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<V::Value, A::Error> {
        self.inner.visit_map(TopMap {
            map,
            fields: self.fields,
            kept: self.kept,
        })
    }
}

struct TopMap<'k, A> {
    map: A,
    fields: &'static [&'static str],
    kept: &'k mut toml::Table,
}

impl<'de, A: MapAccess<'de>> MapAccess<'de> for TopMap<'_, A> {
    type Error = A::Error;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, A::Error> {
        let mut seed = seed;
        loop {
            let key = KeySeed {
                seed,
                fields: self.fields,
            };
            match self.map.next_key_seed(key)? {
                None => return Ok(None),
                Some(Key::Field(k)) => return Ok(Some(k)),
                Some(Key::Other(back, name)) => {
                    let value: toml::Value = self.map.next_value()?;
                    self.kept.insert(name, value);
                    seed = back;
                }
            }
        }
    }

    fn next_value_seed<S: DeserializeSeed<'de>>(&mut self, seed: S) -> Result<S::Value, A::Error> {
        self.map.next_value_seed(seed)
    }
}

/// A top-level key: one of the struct's, or another process's section
/// (its name, and the struct's seed back for the next key).
enum Key<K, T> {
    Field(T),
    Other(K, String),
}

struct KeySeed<K> {
    seed: K,
    fields: &'static [&'static str],
}

impl<'de, K: DeserializeSeed<'de>> DeserializeSeed<'de> for KeySeed<K> {
    type Value = Key<K, K::Value>;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_str(self)
    }
}

impl<'de, K: DeserializeSeed<'de>> Visitor<'de> for KeySeed<K> {
    type Value = Key<K, K::Value>;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a section name")
    }

    fn visit_str<E: de::Error>(self, key: &str) -> Result<Self::Value, E> {
        if OTHER_SECTIONS.contains(&key) {
            return Ok(Key::Other(self.seed, key.to_string()));
        }
        if !self.fields.is_empty() && !self.fields.contains(&key) {
            // serde's own unknown-field text, listing every section the
            // file may have.
            let expected = self
                .fields
                .iter()
                .chain(&OTHER_SECTIONS)
                .map(|f| format!("`{f}`"))
                .collect::<Vec<_>>()
                .join(", ");
            return Err(E::custom(format_args!(
                "unknown field `{key}`, expected one of {expected}"
            )));
        }
        let key: de::value::StrDeserializer<'_, E> = de::IntoDeserializer::into_deserializer(key);
        self.seed.deserialize(key).map(Key::Field)
    }
}
