//! wasm-bindgen tests of the glue, run in Node: `wasm-pack test --node wasm`.
//! They check what the JS tests cannot see from outside: that JS objects map onto the
//! core's types and that core errors cross as JS `Error`s carrying the core's message.
#![cfg(target_arch = "wasm32")]

use js_sys::{Array, Object, Reflect, Uint8Array, Uint8ClampedArray};
use lfdepth_wasm::{evaluate, synthesize, Estimator};
use wasm_bindgen::prelude::*;
use wasm_bindgen_test::wasm_bindgen_test;

fn object(pairs: &[(&str, JsValue)]) -> JsValue {
    let o = Object::new();
    for (k, v) in pairs {
        Reflect::set(&o, &JsValue::from_str(k), v).unwrap();
    }
    o.into()
}

fn shape(size: usize) -> JsValue {
    object(&[
        ("rows", 5.into()),
        ("cols", 5.into()),
        ("width", size.into()),
        ("height", size.into()),
        ("channels", 3.into()),
    ])
}

/// The message of a JsError as JS sees it.
fn message(e: JsError) -> String {
    let value: JsValue = e.into();
    assert!(value.is_instance_of::<js_sys::Error>(), "not an Error");
    value.unchecked_into::<js_sys::Error>().message().into()
}

#[wasm_bindgen_test]
fn estimator_accepts_both_byte_array_types() {
    let spec = object(&[
        ("scene", "slanted".into()),
        ("rows", 5.into()),
        ("cols", 5.into()),
        ("width", 32.into()),
        ("height", 32.into()),
    ]);
    let scene = synthesize(spec).unwrap();
    let views: Uint8Array = scene.views();
    let clamped = Uint8ClampedArray::new(&views.buffer());
    let params = object(&[("range", Array::of2(&(-2.0).into(), &2.0.into()).into())]);
    let a = Estimator::new(views.into(), shape(32), Some(params.clone())).unwrap();
    let b = Estimator::new(clamped.into(), shape(32), Some(params)).unwrap();
    let (mut a, mut b) = (a, b);
    let (ra, rb) = (a.estimate(None).unwrap(), b.estimate(None).unwrap());
    assert_eq!(ra.disparity().to_vec(), rb.disparity().to_vec());
    assert_eq!(a.disparity_range().unwrap(), vec![-2.0, 2.0]);
    let d = ra.disparity().to_vec();
    assert!(d.iter().all(|v| (-2.0..=2.0).contains(v)));
    let gt = scene.ground_truth().to_vec();
    let scores = evaluate(&d, &gt, 32, 32, Some(object(&[("border", 4.into())]))).unwrap();
    assert!((0.0..=100.0).contains(&scores.badpix_007));
    let e = evaluate(&d, &gt, 32, 32, Some(object(&[("border", 16.into())])))
        .err()
        .unwrap();
    assert!(message(e).contains("border"));
}

#[wasm_bindgen_test]
fn core_errors_cross_as_js_errors_with_the_core_message() {
    let views: JsValue = Uint8Array::new_with_length(10).into();
    let e = Estimator::new(views, shape(32), None).err().unwrap();
    assert_eq!(
        message(e),
        lfdepth::Error::BufferTooSmall {
            what: "the light-field buffer",
            needed: 25 * 32 * 32 * 3,
            got: 10
        }
        .to_string()
    );
    let e = Estimator::new(JsValue::from_str("views"), shape(32), None)
        .err()
        .unwrap();
    assert!(message(e).contains("Uint8Array, Uint8ClampedArray or Float32Array"));
    let e = Estimator::new(
        Uint8Array::new_with_length(10).into(),
        shape(32),
        Some(object(&[("outerSigma", JsValue::from_str("wide"))])),
    )
    .err()
    .unwrap();
    assert_eq!(message(e), "params.outerSigma must be a finite number");
    let e = synthesize(JsValue::NULL).err().unwrap();
    assert!(message(e).contains("spec is missing"));
}
