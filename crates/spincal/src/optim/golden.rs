//! Golden-section search for the maximum of a unimodal function of one variable.

/// Maximiser of a unimodal function on [a, b]: golden-section steps, each reusing one inner point
/// (one evaluation per step), until the bracket is within 1e-12 of its end's magnitude or after
/// `max_steps` steps; the bracket's midpoint.
pub fn golden_section_max(f: impl Fn(f64) -> f64, mut a: f64, mut b: f64, max_steps: usize) -> f64 {
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let mut c = b - ratio * (b - a);
    let mut d = a + ratio * (b - a);
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..max_steps {
        if (b - a).abs() <= 1e-12 * b.abs().max(1e-12) {
            break;
        }
        if fc > fd {
            b = d;
            d = c;
            fd = fc;
            c = b - ratio * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + ratio * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}
