//! Serde pieces shared by the meteoblue and Open-Meteo parsers: a time stamp that may be a string,
//! an integer or `null`, and a block of per-variable arrays whose keys are only partly known in
//! advance (pressure-level variables carry the level in the key).
//!
//! Both are deserialized straight from the byte stream (no intermediate `serde_json::Value`), so a
//! wrong JSON type reports its line and column, and unknown keys cost only a skip.

use std::fmt;
use std::marker::PhantomData;

use serde::de::{self, Deserialize, Deserializer, IgnoredAny, MapAccess, Visitor};

/// One entry of a `time` array as written in the file.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum RawTime {
    /// A string: local `"YYYY-MM-DD hh:mm"` or ISO 8601.
    Text(String),
    /// Integer Unix seconds (meteoblue `timestamp_utc`, Open-Meteo `unixtime`).
    Unix(i64),
    /// A number that is not a whole number of seconds in range.
    BadNumber(f64),
    /// `null`.
    Null,
}

impl<'de> Deserialize<'de> for RawTime {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct RawTimeVisitor;

        impl Visitor<'_> for RawTimeVisitor {
            type Value = RawTime;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("a time string or integer Unix seconds")
            }

            fn visit_str<E: de::Error>(self, value: &str) -> Result<RawTime, E> {
                Ok(RawTime::Text(value.to_owned()))
            }

            fn visit_string<E: de::Error>(self, value: String) -> Result<RawTime, E> {
                Ok(RawTime::Text(value))
            }

            fn visit_i64<E: de::Error>(self, value: i64) -> Result<RawTime, E> {
                Ok(RawTime::Unix(value))
            }

            fn visit_u64<E: de::Error>(self, value: u64) -> Result<RawTime, E> {
                Ok(i64::try_from(value).map_or(RawTime::BadNumber(value as f64), RawTime::Unix))
            }

            fn visit_f64<E: de::Error>(self, value: f64) -> Result<RawTime, E> {
                // Some writers emit `1620000000.0`; accept whole seconds within ±2^53.
                if value.fract() == 0.0 && value.abs() < 9.0e15 {
                    Ok(RawTime::Unix(value as i64))
                } else {
                    Ok(RawTime::BadNumber(value))
                }
            }

            fn visit_unit<E: de::Error>(self) -> Result<RawTime, E> {
                Ok(RawTime::Null)
            }

            fn visit_none<E: de::Error>(self) -> Result<RawTime, E> {
                Ok(RawTime::Null)
            }
        }

        deserializer.deserialize_any(RawTimeVisitor)
    }
}

impl fmt::Display for RawTime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Text(text) => f.write_str(text),
            Self::Unix(seconds) => write!(f, "{seconds}"),
            Self::BadNumber(value) => write!(f, "{value}"),
            Self::Null => f.write_str("null"),
        }
    }
}

/// Decides which keys of a data block are variables this crate reads (the rest are skipped).
pub(crate) trait ColumnFilter {
    /// True when `key` names a numeric variable to keep.
    fn wanted(key: &str) -> bool;
}

/// A data block (`data_1h`, `hourly`): its `time` array and the wanted numeric arrays, in file
/// order. `null` entries stay `None`.
#[derive(Debug)]
pub(crate) struct RawBlock<F> {
    pub time: Option<Vec<RawTime>>,
    pub columns: Vec<(String, Vec<Option<f64>>)>,
    filter: PhantomData<F>,
}

impl<'de, F: ColumnFilter> Deserialize<'de> for RawBlock<F> {
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        struct BlockVisitor<F>(PhantomData<F>);

        impl<'de, F: ColumnFilter> Visitor<'de> for BlockVisitor<F> {
            type Value = RawBlock<F>;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("an object of arrays keyed by variable name")
            }

            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<RawBlock<F>, A::Error> {
                let mut block = RawBlock {
                    time: None,
                    columns: Vec::new(),
                    filter: PhantomData,
                };
                while let Some(key) = map.next_key::<String>()? {
                    if key == "time" {
                        if block.time.is_some() {
                            return Err(de::Error::duplicate_field("time"));
                        }
                        block.time = map.next_value::<Option<Vec<RawTime>>>()?;
                    } else if F::wanted(&key) {
                        if block.columns.iter().any(|(name, _)| *name == key) {
                            return Err(de::Error::custom(format_args!("duplicate key `{key}`")));
                        }
                        // A whole variable written as `null` is treated as absent.
                        if let Some(values) = map.next_value::<Option<Vec<Option<f64>>>>()? {
                            block.columns.push((key, values));
                        }
                    } else {
                        map.next_value::<IgnoredAny>()?;
                    }
                }
                Ok(block)
            }
        }

        deserializer.deserialize_map(BlockVisitor(PhantomData))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct OnlyCover;

    impl ColumnFilter for OnlyCover {
        fn wanted(key: &str) -> bool {
            key == "lowclouds"
        }
    }

    #[test]
    fn block_keeps_wanted_columns_and_nulls() {
        let block: RawBlock<OnlyCover> = serde_json::from_str(
            r#"{"time": ["2021-05-03 00:00", 1620000000, 1620003600.0, null, 0.5],
                "rainspot": ["0000", "9"], "lowclouds": [30, null, 20.5, 0, 1],
                "data": {"nested": [1, {"x": 2}]}}"#,
        )
        .unwrap();
        assert_eq!(
            block.time.unwrap(),
            vec![
                RawTime::Text("2021-05-03 00:00".into()),
                RawTime::Unix(1_620_000_000),
                RawTime::Unix(1_620_003_600),
                RawTime::Null,
                RawTime::BadNumber(0.5),
            ]
        );
        assert_eq!(
            block.columns,
            vec![(
                "lowclouds".to_owned(),
                vec![Some(30.0), None, Some(20.5), Some(0.0), Some(1.0)]
            )]
        );
    }

    #[test]
    fn block_rejects_duplicates_and_wrong_types() {
        assert!(
            serde_json::from_str::<RawBlock<OnlyCover>>(r#"{"lowclouds": [1], "lowclouds": [2]}"#)
                .is_err()
        );
        assert!(
            serde_json::from_str::<RawBlock<OnlyCover>>(r#"{"time": [], "time": []}"#).is_err()
        );
        assert!(serde_json::from_str::<RawBlock<OnlyCover>>(r#"{"lowclouds": ["x"]}"#).is_err());
        assert!(serde_json::from_str::<RawBlock<OnlyCover>>(r#"{"time": [true]}"#).is_err());
        assert!(serde_json::from_str::<RawBlock<OnlyCover>>("[1, 2]").is_err());
    }
}
