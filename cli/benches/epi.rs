//! Criterion benchmarks of the epi stage (filled in with the stage).

use criterion::{criterion_group, criterion_main, Criterion};

fn placeholder(c: &mut Criterion) {
    c.bench_function("epi/q16_mul", |b| {
        let x = lfdepth::Q16::from_raw(123_456);
        b.iter(|| criterion::black_box(x) * criterion::black_box(x))
    });
}

criterion_group!(benches, placeholder);
criterion_main!(benches);
