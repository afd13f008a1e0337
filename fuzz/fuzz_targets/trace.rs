//! Trace CSV reader (`Trace::parse`): the input is the file's text (non-UTF-8 inputs are
//! skipped: the runner reads traces with `read_to_string`, which refuses them first).
//!
//! Properties: no panic; an error names a line of the text and prints on one line; an accepted
//! trace is non-empty, finite, in non-decreasing time with unit quaternions, its own CSV
//! (`to_csv`) parses back to the same samples, and `sample_at` stays finite anywhere.

#![no_main]

use libfuzzer_sys::fuzz_target;
use tetradrill_device::Trace;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let trace = match Trace::parse(text, "fuzz.csv") {
        Ok(t) => t,
        Err(e) => {
            let lines = text.lines().count().max(1);
            assert!(e.line >= 1 && e.line <= lines, "line {} of {lines}", e.line);
            let msg = e.at("fuzz.csv").to_string();
            assert!(!msg.contains(['\n', '\r']), "error not one line: {msg:?}");
            return;
        }
    };
    assert!(!trace.is_empty());
    let mut last_t = f64::NEG_INFINITY;
    for s in trace.samples() {
        assert!(
            s.t.is_finite() && s.t >= last_t,
            "time {} after {last_t}",
            s.t
        );
        last_t = s.t;
        assert!(s.position.iter().all(|v| v.is_finite()));
        let n: f64 = s.rotation.iter().map(|v| v * v).sum::<f64>().sqrt();
        assert!((n - 1.0).abs() < 1e-9, "quaternion norm {n}");
    }
    let again = Trace::parse(&trace.to_csv(), "fuzz.csv").expect("a trace's own CSV parses");
    assert_eq!(again.len(), trace.len());
    for (a, b) in trace.samples().iter().zip(again.samples()) {
        assert_eq!(a.t.to_bits(), b.t.to_bits());
        assert_eq!(a.position.map(f64::to_bits), b.position.map(f64::to_bits));
        assert_eq!(a.buttons, b.buttons);
        for (p, q) in a.rotation.iter().zip(&b.rotation) {
            assert!((p - q).abs() <= 1e-15, "rotation drifted: {p} vs {q}");
        }
    }
    let (t0, t1) = trace.time_span().expect("non-empty");
    for t in [t0 - 1.0, t0, 0.5 * (t0 + t1), t1, t1 + 1.0, f64::NAN] {
        let s = trace.sample_at(t).expect("non-empty");
        assert!(
            s.position.iter().all(|v| v.is_finite()),
            "sample_at({t}) not finite"
        );
        assert!(
            s.rotation.iter().all(|v| v.is_finite()),
            "sample_at({t}) not finite"
        );
    }
});
