//! Min/max decimation: a long series drawn with at most two points per pixel column looks the same.

/// Thins `(x, y)` to at most about `2 · columns + 2` points that draw the same picture on a plot
/// `columns` pixels wide: the x range is cut into `columns` equal bins and every run of points in one
/// bin is replaced by its minimum and maximum, in their original order. The first and last points are
/// kept, and so is every extreme. A non-finite y inside a bin is kept once after the bin's extremes, so
/// gaps in a line survive. Series not longer than `2 · columns` come back unchanged.
///
/// Panics if `x` and `y` differ in length.
pub fn decimate_min_max(x: &[f64], y: &[f64], columns: usize) -> (Vec<f64>, Vec<f64>) {
    assert_eq!(x.len(), y.len(), "decimate_min_max: x and y differ in length");
    let columns = columns.max(1);
    if x.len() <= 2 * columns {
        return (x.to_vec(), y.to_vec());
    }
    let (lo, hi) = x
        .iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    if hi <= lo {
        return (x.to_vec(), y.to_vec());
    }
    let scale = columns as f64 / (hi - lo);
    let bin_of = |v: f64| {
        if v.is_finite() {
            (((v - lo) * scale) as usize).min(columns - 1)
        } else {
            usize::MAX
        }
    };

    let mut out_x = Vec::with_capacity(2 * columns + 4);
    let mut out_y = Vec::with_capacity(2 * columns + 4);
    let last = x.len() - 1;
    let mut start = 0;
    while start < x.len() {
        let bin = bin_of(x[start]);
        let mut end = start + 1;
        while end < x.len() && bin_of(x[end]) == bin {
            end += 1;
        }
        // Extremes of this run, in index order, plus a gap marker if any y was not finite.
        let (mut i_min, mut i_max, mut gap) = (None::<usize>, None::<usize>, None::<usize>);
        for i in start..end {
            if !y[i].is_finite() {
                gap.get_or_insert(i);
                continue;
            }
            if i_min.is_none_or(|m| y[i] < y[m]) {
                i_min = Some(i);
            }
            if i_max.is_none_or(|m| y[i] > y[m]) {
                i_max = Some(i);
            }
        }
        let mut keep: Vec<usize> = [Some(start).filter(|_| start == 0), i_min, i_max, Some(last)]
            .into_iter()
            .flatten()
            .filter(|&i| i >= start && i < end)
            .collect();
        keep.sort_unstable();
        keep.dedup();
        for i in keep {
            out_x.push(x[i]);
            out_y.push(y[i]);
        }
        if let Some(g) = gap {
            out_x.push(x[g]);
            out_y.push(f64::NAN);
        }
        start = end;
    }
    (out_x, out_y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_extremes_and_ends_of_a_long_series() {
        let n = 60_000;
        let x: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let mut y: Vec<f64> = x.iter().map(|t| (2.0 * t).sin()).collect();
        y[12_345] = 7.0;
        y[40_001] = -9.0;
        let (dx, dy) = decimate_min_max(&x, &y, 800);
        assert!(dx.len() <= 2 * 800 + 2, "{}", dx.len());
        assert!(dx.len() >= 800);
        assert_eq!((dx[0], dy[0]), (x[0], y[0]));
        assert_eq!((*dx.last().unwrap(), *dy.last().unwrap()), (x[n - 1], y[n - 1]));
        assert!(dy.contains(&7.0) && dy.contains(&-9.0));
        assert!(dx.windows(2).all(|w| w[0] <= w[1]), "order kept");
        // Every column's extreme survives: max over any bin of the decimated series equals the original.
        let bin = |v: f64| ((v / x[n - 1]) * 800.0).min(799.0) as usize;
        let mut max_orig = vec![f64::NEG_INFINITY; 800];
        let mut max_dec = vec![f64::NEG_INFINITY; 800];
        for (&a, &b) in x.iter().zip(&y) {
            max_orig[bin(a)] = max_orig[bin(a)].max(b);
        }
        for (&a, &b) in dx.iter().zip(&dy) {
            max_dec[bin(a)] = max_dec[bin(a)].max(b);
        }
        assert_eq!(max_orig, max_dec);
    }

    #[test]
    fn short_series_unchanged_and_gaps_kept() {
        let x = [0.0, 1.0, 2.0];
        assert_eq!(decimate_min_max(&x, &x, 10), (x.to_vec(), x.to_vec()));
        let x: Vec<f64> = (0..1000).map(f64::from).collect();
        let mut y = x.clone();
        y[500] = f64::NAN;
        let (_, dy) = decimate_min_max(&x, &y, 10);
        assert_eq!(dy.iter().filter(|v| v.is_nan()).count(), 1);
        assert!(dy.len() <= 23);
    }
}
