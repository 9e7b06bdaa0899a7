//! `Report`: named numbers and strings, the common output of evaluation nodes. The executor
//! shows every Report a run produces in the summary and the JSON log.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

/// One reported value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ReportValue {
    Num(f64),
    Text(String),
}

impl From<f64> for ReportValue {
    fn from(v: f64) -> Self {
        ReportValue::Num(v)
    }
}
impl From<usize> for ReportValue {
    fn from(v: usize) -> Self {
        ReportValue::Num(v as f64)
    }
}
impl From<&str> for ReportValue {
    fn from(v: &str) -> Self {
        ReportValue::Text(v.to_string())
    }
}
impl From<String> for ReportValue {
    fn from(v: String) -> Self {
        ReportValue::Text(v)
    }
}

/// Named values in name order (so digests and tables are stable).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Report {
    pub values: BTreeMap<String, ReportValue>,
}

impl Report {
    pub fn new() -> Self {
        Self::default()
    }
    pub fn set(&mut self, name: impl Into<String>, value: impl Into<ReportValue>) -> &mut Self {
        self.values.insert(name.into(), value.into());
        self
    }
    pub fn num(&self, name: &str) -> Option<f64> {
        match self.values.get(name) {
            Some(ReportValue::Num(v)) => Some(*v),
            _ => None,
        }
    }
    pub fn text(&self, name: &str) -> Option<&str> {
        match self.values.get(name) {
            Some(ReportValue::Text(v)) => Some(v),
            _ => None,
        }
    }
    /// Adds every value of `other` under `prefix.` (for reports that gather others).
    pub fn merge_prefixed(&mut self, prefix: &str, other: &Report) {
        for (k, v) in &other.values {
            self.values.insert(format!("{prefix}.{k}"), v.clone());
        }
    }
    /// The values as a JSON object (numbers stay numbers; NaN and infinities become null).
    pub fn to_json(&self) -> serde_json::Value {
        let mut map = serde_json::Map::new();
        for (k, v) in &self.values {
            let j = match v {
                ReportValue::Num(x) => serde_json::Number::from_f64(*x)
                    .map(serde_json::Value::Number)
                    .unwrap_or(serde_json::Value::Null),
                ReportValue::Text(s) => serde_json::Value::String(s.clone()),
            };
            map.insert(k.clone(), j);
        }
        serde_json::Value::Object(map)
    }
}
