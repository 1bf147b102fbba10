//! Reading plain JS objects and turning core errors into JS `Error`s.

use js_sys::{Object, Reflect};
use wasm_bindgen::prelude::*;

/// A core error as a JS `Error` carrying the core's message.
pub fn error(e: lfdepth::Error) -> JsError {
    JsError::new(&e.to_string())
}

/// A JS `Error` with `message`.
pub fn message(message: &str) -> JsError {
    JsError::new(message)
}

/// A plain object's fields, with the names it may have, for error messages that say what
/// to change.
pub struct Fields<'a> {
    object: &'a JsValue,
    what: &'static str,
}

impl<'a> Fields<'a> {
    /// `object` must be a non-null object (or `undefined`/`null` when `optional`) whose
    /// keys are all in `known`.
    pub fn new(
        object: &'a JsValue,
        what: &'static str,
        known: &[&str],
        optional: bool,
    ) -> Result<Self, JsError> {
        if object.is_undefined() || object.is_null() {
            if optional {
                return Ok(Fields { object, what });
            }
            return Err(message(&format!("{what} is missing: pass an object")));
        }
        if !object.is_object() {
            return Err(message(&format!("{what} must be an object")));
        }
        for key in Object::keys(object.unchecked_ref::<Object>()).iter() {
            let key = key.as_string().unwrap_or_default();
            if !known.contains(&key.as_str()) {
                return Err(message(&format!(
                    "{what} has an unknown key `{key}`: the known keys are {}",
                    known.join(", ")
                )));
            }
        }
        Ok(Fields { object, what })
    }

    /// The raw value of `key` (`undefined` when absent).
    pub fn get(&self, key: &str) -> JsValue {
        if self.object.is_object() {
            Reflect::get(self.object, &JsValue::from_str(key)).unwrap_or(JsValue::UNDEFINED)
        } else {
            JsValue::UNDEFINED
        }
    }

    /// A number, `None` when absent.
    pub fn number(&self, key: &str) -> Result<Option<f64>, JsError> {
        let v = self.get(key);
        if v.is_undefined() {
            return Ok(None);
        }
        match v.as_f64() {
            Some(n) if n.is_finite() => Ok(Some(n)),
            _ => Err(message(&format!(
                "{}.{key} must be a finite number",
                self.what
            ))),
        }
    }

    /// A non-negative integer, `None` when absent.
    pub fn count(&self, key: &str) -> Result<Option<usize>, JsError> {
        match self.number(key)? {
            None => Ok(None),
            Some(n) if n >= 0.0 && n.fract() == 0.0 && n <= u32::MAX as f64 => Ok(Some(n as usize)),
            Some(n) => Err(message(&format!(
                "{}.{key} must be a non-negative integer, not {n}",
                self.what
            ))),
        }
    }

    /// A required non-negative integer.
    pub fn required_count(&self, key: &str) -> Result<usize, JsError> {
        self.count(key)?
            .ok_or_else(|| message(&format!("{}.{key} is missing", self.what)))
    }

    /// A boolean, `None` when absent.
    pub fn boolean(&self, key: &str) -> Result<Option<bool>, JsError> {
        let v = self.get(key);
        if v.is_undefined() {
            return Ok(None);
        }
        v.as_bool()
            .map(Some)
            .ok_or_else(|| message(&format!("{}.{key} must be true or false", self.what)))
    }

    /// A string, `None` when absent.
    pub fn string(&self, key: &str) -> Result<Option<String>, JsError> {
        let v = self.get(key);
        if v.is_undefined() {
            return Ok(None);
        }
        v.as_string()
            .map(Some)
            .ok_or_else(|| message(&format!("{}.{key} must be a string", self.what)))
    }
}

/// Milliseconds from `performance.now()` (0 where there is no `performance`).
pub fn now_ms() -> f64 {
    let global = js_sys::global();
    let Ok(performance) = Reflect::get(&global, &JsValue::from_str("performance")) else {
        return 0.0;
    };
    let Ok(now) = Reflect::get(&performance, &JsValue::from_str("now")) else {
        return 0.0;
    };
    now.dyn_ref::<js_sys::Function>()
        .and_then(|f| f.call0(&performance).ok())
        .and_then(|v| v.as_f64())
        .unwrap_or(0.0)
}

/// `value` as a `Uint8Array`: itself, or a `Uint8ClampedArray` viewed over the same
/// bytes (no copy); `None` for anything else.
pub fn u8_array(value: &JsValue) -> Option<js_sys::Uint8Array> {
    if let Some(a) = value.dyn_ref::<js_sys::Uint8Array>() {
        return Some(a.clone());
    }
    let a = value.dyn_ref::<js_sys::Uint8ClampedArray>()?;
    Some(js_sys::Uint8Array::new_with_byte_offset_and_length(
        &a.buffer(),
        a.byte_offset(),
        a.length(),
    ))
}
