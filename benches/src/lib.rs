//! Criterion benchmarks for the sahara workspace (see `benches/`).
