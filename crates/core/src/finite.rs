//! Every float an artifact holds is finite or says, typed, that it is not. JSON has no NaN or
//! infinity and serde_json writes them as `null`, which cannot be told from an absent value
//! and which a stage reading the artifact back took for an error in its own cache file. Written
//! through [`Tagged`], a non-finite float becomes `{"not_finite": "NaN" | "+inf" | "-inf"}`:
//! an explicit absence of a number that names what was there, which [`super::lenient`] reads
//! back as the same float and the report renders as "not finite".

use serde::ser::{self, Serialize, Serializer};

/// The key of the object a non-finite float is written as.
pub const KEY: &str = "not_finite";

/// What a non-finite float is written as (the value under [`KEY`]).
pub fn word(x: f64) -> &'static str {
    if x.is_nan() {
        "NaN"
    } else if x > 0.0 {
        "+inf"
    } else {
        "-inf"
    }
}

/// The float a [`word`] stands for, if it is one.
pub fn from_word(w: &str) -> Option<f64> {
    match w {
        "NaN" => Some(f64::NAN),
        "+inf" => Some(f64::INFINITY),
        "-inf" => Some(f64::NEG_INFINITY),
        _ => None,
    }
}

/// A float as an artifact may hold it where no [`super::lenient`] reader reaches (a field of a
/// flattened struct, which serde buffers): a number, the tagged absence, or `null`.
#[derive(Debug, Clone, serde::Deserialize)]
#[serde(untagged)]
pub enum Loose {
    Number(f64),
    Tagged { not_finite: String },
    Null(Option<()>),
}

impl Loose {
    pub fn value(self) -> Result<f64, String> {
        match self {
            Loose::Number(x) => Ok(x),
            Loose::Tagged { not_finite } => from_word(&not_finite)
                .ok_or_else(|| format!("not_finite: {not_finite:?}, expected NaN, +inf or -inf")),
            Loose::Null(_) => Ok(f64::NAN),
        }
    }
}

/// `value` as pretty JSON with its non-finite floats tagged.
pub fn to_string_pretty<T: Serialize + ?Sized>(value: &T) -> serde_json::Result<String> {
    let mut out = Vec::new();
    let mut s = serde_json::Serializer::pretty(&mut out);
    value.serialize(Tagged(&mut s))?;
    Ok(String::from_utf8(out).expect("serde_json writes UTF-8"))
}

/// `value` as a JSON value with its non-finite floats tagged.
pub fn to_value<T: Serialize + ?Sized>(value: &T) -> serde_json::Result<serde_json::Value> {
    value.serialize(Tagged(serde_json::value::Serializer))
}

/// For a field whose NaN means "none given" (a standard error a method does not give): NaN is
/// written `null`, the documented absence; an infinity is tagged as everywhere else.
pub fn nan_as_null<S: Serializer>(x: &f64, s: S) -> Result<S::Ok, S::Error> {
    if x.is_nan() {
        s.serialize_none()
    } else {
        s.serialize_f64(*x)
    }
}

/// A serializer that writes non-finite floats tagged, at any depth, and all else as `S` does.
pub struct Tagged<S>(pub S);

/// A value serialized through [`Tagged`].
struct Inner<'a, T: ?Sized>(&'a T);

impl<T: Serialize + ?Sized> Serialize for Inner<'_, T> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        self.0.serialize(Tagged(s))
    }
}

/// A compound serializer whose elements go through [`Tagged`].
pub struct Compound<C>(C);

macro_rules! forward_scalar {
    ($($name:ident($ty:ty)),* $(,)?) => {$(
        fn $name(self, v: $ty) -> Result<S::Ok, S::Error> {
            self.0.$name(v)
        }
    )*};
}

impl<S: Serializer> Serializer for Tagged<S> {
    type Ok = S::Ok;
    type Error = S::Error;
    type SerializeSeq = Compound<S::SerializeSeq>;
    type SerializeTuple = Compound<S::SerializeTuple>;
    type SerializeTupleStruct = Compound<S::SerializeTupleStruct>;
    type SerializeTupleVariant = Compound<S::SerializeTupleVariant>;
    type SerializeMap = Compound<S::SerializeMap>;
    type SerializeStruct = Compound<S::SerializeStruct>;
    type SerializeStructVariant = Compound<S::SerializeStructVariant>;

    forward_scalar!(
        serialize_bool(bool),
        serialize_i8(i8),
        serialize_i16(i16),
        serialize_i32(i32),
        serialize_i64(i64),
        serialize_i128(i128),
        serialize_u8(u8),
        serialize_u16(u16),
        serialize_u32(u32),
        serialize_u64(u64),
        serialize_u128(u128),
        serialize_char(char),
        serialize_str(&str),
        serialize_bytes(&[u8]),
        serialize_unit_struct(&'static str),
    );

    fn serialize_f32(self, v: f32) -> Result<S::Ok, S::Error> {
        self.serialize_f64(v as f64)
    }

    fn serialize_f64(self, v: f64) -> Result<S::Ok, S::Error> {
        if v.is_finite() {
            return self.0.serialize_f64(v);
        }
        let mut m = self.0.serialize_map(Some(1))?;
        ser::SerializeMap::serialize_entry(&mut m, KEY, word(v))?;
        ser::SerializeMap::end(m)
    }

    fn serialize_none(self) -> Result<S::Ok, S::Error> {
        self.0.serialize_none()
    }

    fn serialize_some<T: Serialize + ?Sized>(self, v: &T) -> Result<S::Ok, S::Error> {
        self.0.serialize_some(&Inner(v))
    }

    fn serialize_unit(self) -> Result<S::Ok, S::Error> {
        self.0.serialize_unit()
    }

    fn serialize_unit_variant(
        self,
        name: &'static str,
        index: u32,
        variant: &'static str,
    ) -> Result<S::Ok, S::Error> {
        self.0.serialize_unit_variant(name, index, variant)
    }

    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        name: &'static str,
        v: &T,
    ) -> Result<S::Ok, S::Error> {
        self.0.serialize_newtype_struct(name, &Inner(v))
    }

    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        name: &'static str,
        index: u32,
        variant: &'static str,
        v: &T,
    ) -> Result<S::Ok, S::Error> {
        self.0
            .serialize_newtype_variant(name, index, variant, &Inner(v))
    }

    fn serialize_seq(self, len: Option<usize>) -> Result<Self::SerializeSeq, S::Error> {
        self.0.serialize_seq(len).map(Compound)
    }

    fn serialize_tuple(self, len: usize) -> Result<Self::SerializeTuple, S::Error> {
        self.0.serialize_tuple(len).map(Compound)
    }

    fn serialize_tuple_struct(
        self,
        name: &'static str,
        len: usize,
    ) -> Result<Self::SerializeTupleStruct, S::Error> {
        self.0.serialize_tuple_struct(name, len).map(Compound)
    }

    fn serialize_tuple_variant(
        self,
        name: &'static str,
        index: u32,
        variant: &'static str,
        len: usize,
    ) -> Result<Self::SerializeTupleVariant, S::Error> {
        self.0
            .serialize_tuple_variant(name, index, variant, len)
            .map(Compound)
    }

    fn serialize_map(self, len: Option<usize>) -> Result<Self::SerializeMap, S::Error> {
        self.0.serialize_map(len).map(Compound)
    }

    fn serialize_struct(
        self,
        name: &'static str,
        len: usize,
    ) -> Result<Self::SerializeStruct, S::Error> {
        self.0.serialize_struct(name, len).map(Compound)
    }

    fn serialize_struct_variant(
        self,
        name: &'static str,
        index: u32,
        variant: &'static str,
        len: usize,
    ) -> Result<Self::SerializeStructVariant, S::Error> {
        self.0
            .serialize_struct_variant(name, index, variant, len)
            .map(Compound)
    }

    fn is_human_readable(&self) -> bool {
        self.0.is_human_readable()
    }
}

macro_rules! compound {
    ($trait:ident, $method:ident) => {
        impl<C: ser::$trait> ser::$trait for Compound<C> {
            type Ok = C::Ok;
            type Error = C::Error;

            fn $method<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), C::Error> {
                self.0.$method(&Inner(v))
            }

            fn end(self) -> Result<C::Ok, C::Error> {
                self.0.end()
            }
        }
    };
}

compound!(SerializeSeq, serialize_element);
compound!(SerializeTuple, serialize_element);
compound!(SerializeTupleStruct, serialize_field);
compound!(SerializeTupleVariant, serialize_field);

impl<C: ser::SerializeMap> ser::SerializeMap for Compound<C> {
    type Ok = C::Ok;
    type Error = C::Error;

    fn serialize_key<T: Serialize + ?Sized>(&mut self, k: &T) -> Result<(), C::Error> {
        self.0.serialize_key(&Inner(k))
    }

    fn serialize_value<T: Serialize + ?Sized>(&mut self, v: &T) -> Result<(), C::Error> {
        self.0.serialize_value(&Inner(v))
    }

    fn end(self) -> Result<C::Ok, C::Error> {
        self.0.end()
    }
}

macro_rules! fields {
    ($trait:ident) => {
        impl<C: ser::$trait> ser::$trait for Compound<C> {
            type Ok = C::Ok;
            type Error = C::Error;

            fn serialize_field<T: Serialize + ?Sized>(
                &mut self,
                key: &'static str,
                v: &T,
            ) -> Result<(), C::Error> {
                self.0.serialize_field(key, &Inner(v))
            }

            fn skip_field(&mut self, key: &'static str) -> Result<(), C::Error> {
                self.0.skip_field(key)
            }

            fn end(self) -> Result<C::Ok, C::Error> {
                self.0.end()
            }
        }
    };
}

fields!(SerializeStruct);
fields!(SerializeStructVariant);

#[cfg(test)]
mod tests {
    use super::*;
    use serde::{Deserialize, Serialize};
    use std::collections::BTreeMap;

    #[derive(Debug, Serialize, Deserialize)]
    enum E {
        S { y: f64 },
        T(f64, f32),
        N(f64),
    }

    #[derive(Debug, Serialize, Deserialize)]
    struct Doc {
        a: f64,
        v: Vec<f64>,
        o: Option<f64>,
        none: Option<f64>,
        by: BTreeMap<String, (f64, f64)>,
        e: Vec<E>,
        value: serde_json::Value,
        n: usize,
    }

    fn same(a: f64, b: f64) -> bool {
        a == b || (a.is_nan() && b.is_nan())
    }

    #[test]
    fn non_finite_floats_are_tagged_and_read_back_as_themselves() {
        let (nan, inf) = (f64::NAN, f64::INFINITY);
        let doc = Doc {
            a: nan,
            v: vec![1.5, -inf, inf],
            o: Some(nan),
            none: None,
            by: [("k".to_string(), (inf, 2.0))].into(),
            e: vec![E::S { y: -inf }, E::T(nan, f32::INFINITY), E::N(0.25)],
            value: to_value(&[nan, 3.0]).unwrap(),
            n: 7,
        };
        let text = to_string_pretty(&doc).unwrap();
        assert_eq!(text.matches("\"not_finite\"").count(), 9, "{text}");
        assert!(text.contains("\"none\": null"), "{text}");
        let back: Doc = super::super::lenient::from_str(&text).unwrap();
        assert!(same(back.a, nan) && same(back.v[1], -inf) && same(back.v[2], inf));
        assert!(back.o.is_some_and(f64::is_nan) && back.none.is_none());
        assert!(same(back.by["k"].0, inf) && back.by["k"].1 == 2.0);
        assert!(matches!(back.e[0], E::S { y } if y == -inf));
        assert!(matches!(back.e[1], E::T(x, y) if x.is_nan() && y == f32::INFINITY));
        assert!(matches!(back.e[2], E::N(x) if x == 0.25));
        assert_eq!(back.value[0][KEY], "NaN");
        assert_eq!((back.v[0], back.n), (1.5, 7));
        // Finite floats are written exactly as serde_json writes them.
        assert_eq!(
            to_string_pretty(&[0.1, 1e300]).unwrap(),
            serde_json::to_string_pretty(&[0.1, 1e300]).unwrap()
        );
    }

    #[test]
    fn a_tag_with_an_unknown_word_is_an_error() {
        let r: Result<Vec<f64>, _> = super::super::lenient::from_str(r#"[{"not_finite": "big"}]"#);
        assert!(r.unwrap_err().to_string().contains("big"));
    }
}
