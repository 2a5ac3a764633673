//! The Allan deviation's log-log figure.

use crate::allan::{AllanCurve, NoiseParams};
use crate::report::plot::{LinePlot, LineStyle, Rgb, Series};

/// The log-log figure of the three curves with the fitted −½ lines (noise density read-off).
pub fn allan_figure(curve: &AllanCurve, params: &NoiseParams, title: &str) -> LinePlot {
    let mut plot = LinePlot::new(title, "τ (s)", "Allan deviation σ(τ) (m/s²)")
        .log_x()
        .log_y();
    for a in 0..3 {
        let axis = ["x", "y", "z"][a];
        let color = Rgb::palette(a);
        plot = plot.series(Series::new(axis, curve.tau_s.clone(), curve.adev[a].clone()).color(color));
        // N/√τ, the white-noise asymptote whose value at τ = 1 s is the noise density.
        let fit: Vec<f64> = curve
            .tau_s
            .iter()
            .map(|t| params.noise_density[a] / t.sqrt())
            .collect();
        plot = plot.series(
            Series::new(
                format!("{axis}: N = {:.2e} m/s²/√Hz", params.noise_density[a]),
                curve.tau_s.clone(),
                fit,
            )
            .color(color)
            .style(LineStyle::Dashed)
            .width(1),
        );
    }
    plot
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::allan::{allan_deviation, noise_params};
    use crate::report::plot::Figure;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    #[test]
    fn figure_draws_as_svg() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        let d = Normal::new(0.0, 0.01).unwrap();
        let axes: [Vec<f64>; 3] = std::array::from_fn(|_| (0..2000).map(|_| d.sample(&mut rng)).collect());
        let curve = allan_deviation(&axes, 0.01, 10).unwrap();
        let svg = allan_figure(&curve, &noise_params(&curve), "test")
            .to_svg()
            .unwrap();
        assert!(
            svg.starts_with("<svg") && svg.contains("m/s²/√Hz"),
            "{}",
            &svg[..200.min(svg.len())]
        );
    }
}
