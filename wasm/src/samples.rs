//! The samples of an estimator's views: 8-bit as the caller gives them, or `f32`
//! (intensity in nominal `[0, 1]`) as a caller may give them and as the alignment leaves
//! the views it warped. Warped views stay `f32`, never rounded to 8 bits, as the `lfdepth`
//! tool keeps them: an aligned array gives the tool's map bit for bit.

use wasm_bindgen::prelude::*;

use crate::js::{self, message};

/// The packed views of a light field, in their sample type.
pub(crate) enum Samples {
    /// 8-bit samples (`Uint8Array`, `Uint8ClampedArray`).
    U8(Vec<u8>),
    /// `f32` samples (`Float32Array`), intensity in nominal `[0, 1]`.
    F32(Vec<f32>),
}

/// Runs `$body` with `$lf` bound to `LightField::new(samples, layout)` (a
/// `Result<LightField<'_, S>>`) in the samples' type: one body, both sample types.
macro_rules! with_light_field {
    ($samples:expr, $layout:expr, |$lf:ident| $body:expr) => {
        match $samples {
            $crate::samples::Samples::U8(samples) => {
                let $lf = lfdepth::LightField::new(&samples[..], $layout);
                $body
            }
            $crate::samples::Samples::F32(samples) => {
                let $lf = lfdepth::LightField::new(&samples[..], $layout);
                $body
            }
        }
    };
}
pub(crate) use with_light_field;

impl Samples {
    /// A copy of a `Uint8Array`, `Uint8ClampedArray` or `Float32Array`.
    pub(crate) fn from_js(value: &JsValue, what: &str) -> Result<Samples, JsError> {
        if let Some(a) = js::u8_array(value) {
            return Ok(Samples::U8(a.to_vec()));
        }
        if let Some(a) = value.dyn_ref::<js_sys::Float32Array>() {
            return Ok(Samples::F32(a.to_vec()));
        }
        Err(message(&format!(
            "{what} must be a Uint8Array, Uint8ClampedArray or Float32Array"
        )))
    }

    /// `len` zero samples of the type of `like` (a `Float32Array` gives `f32`, anything
    /// else 8-bit).
    pub(crate) fn zeros_like(like: &JsValue, len: usize) -> Samples {
        if like.is_instance_of::<js_sys::Float32Array>() {
            Samples::F32(vec![0.0; len])
        } else {
            Samples::U8(vec![0; len])
        }
    }

    /// Copies the typed array `value`, of this buffer's type and exactly `range.len()`
    /// samples, into `range`; else says what `value` is.
    pub(crate) fn copy_in(
        &mut self,
        value: &JsValue,
        range: core::ops::Range<usize>,
    ) -> Result<(), String> {
        let want = range.len();
        match self {
            Samples::U8(samples) => {
                let a = js::u8_array(value)
                    .ok_or_else(|| "another type (the first view is a Uint8Array)".to_string())?;
                let out = samples
                    .get_mut(range)
                    .ok_or("a view beyond the light field")?;
                if a.length() as usize != want {
                    return Err(format!("{} bytes", a.length()));
                }
                a.copy_to(out);
            }
            Samples::F32(samples) => {
                let a = value
                    .dyn_ref::<js_sys::Float32Array>()
                    .ok_or_else(|| "another type (the first view is a Float32Array)".to_string())?;
                let out = samples
                    .get_mut(range)
                    .ok_or("a view beyond the light field")?;
                if a.length() as usize != want {
                    return Err(format!("{} samples", a.length()));
                }
                a.copy_to(out);
            }
        }
        Ok(())
    }

    /// The whole buffer as a JS typed array (a copy): `Uint8Array` or `Float32Array`.
    pub(crate) fn to_js(&self) -> JsValue {
        match self {
            Samples::U8(samples) => js_sys::Uint8Array::from(&samples[..]).into(),
            Samples::F32(samples) => js_sys::Float32Array::from(&samples[..]).into(),
        }
    }

    /// The views at `indices` (each `len` samples), packed one after the other into a
    /// new typed array of this buffer's type.
    pub(crate) fn packed_js(&self, indices: &[usize], len: usize) -> JsValue {
        let total = (indices.len() * len) as u32;
        let span = |i: usize| (i * len) as u32..((i + 1) * len) as u32;
        let view = |index: usize| index * len..(index + 1) * len;
        match self {
            Samples::U8(samples) => {
                let out = js_sys::Uint8Array::new_with_length(total);
                for (i, &index) in indices.iter().enumerate() {
                    if let Some(view) = samples.get(view(index)) {
                        let at = span(i);
                        out.subarray(at.start, at.end).copy_from(view);
                    }
                }
                out.into()
            }
            Samples::F32(samples) => {
                let out = js_sys::Float32Array::new_with_length(total);
                for (i, &index) in indices.iter().enumerate() {
                    if let Some(view) = samples.get(view(index)) {
                        let at = span(i);
                        out.subarray(at.start, at.end).copy_from(view);
                    }
                }
                out.into()
            }
        }
    }
}
