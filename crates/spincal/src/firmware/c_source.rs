//! The C99 export: a header and a source per precision, with no dynamic memory and nothing
//! beyond `<math.h>` (and the freestanding `<stdint.h>` for the tanh's exponent bits).
//!
//! Every operation is written in the order the library's stream does it, with the coefficients
//! [`super::plan`] derived by the library's arithmetic, so the `double` build repeats
//! `spincal correct`'s arithmetic (compiled without contraction of multiply-adds, the default of
//! `-std=c99`), and the `float` build does the same operations in single precision.

use std::fmt::Write;

use super::plan::{
    AccelPlan, CoveragePlan, GyroPlan, LinearPlan, NetworkPlan, PhysicalPlan, Plan, StaticPlan,
};
use super::Precision;

/// One member of the coefficient struct.
struct Field {
    name: String,
    dims: Vec<usize>,
    values: Values,
    doc: String,
}

enum Values {
    Real(Vec<f64>),
    Bytes(Vec<u8>),
}

fn real(name: &str, dims: &[usize], values: Vec<f64>, doc: &str) -> Field {
    Field {
        name: name.into(),
        dims: dims.to_vec(),
        values: Values::Real(values),
        doc: doc.into(),
    }
}

/// The C spelling of `x` in `precision`: the shortest decimal that reads back as the same
/// float (for `float`, of x rounded to single precision once).
pub(crate) fn literal(x: f64, precision: Precision) -> String {
    match precision {
        Precision::Double => format!("{x:?}"),
        Precision::Float => format!("{:?}f", x as f32),
    }
}

struct Names {
    /// `spincal_f32`
    p: String,
    /// `SPINCAL_F32`
    u: String,
    /// `float`
    r: &'static str,
    /// `f` for float's math functions, empty for double's
    m: &'static str,
}

impl Names {
    fn new(name: &str, precision: Precision) -> Names {
        let p = format!("{name}_{}", precision.suffix());
        Names {
            u: p.to_ascii_uppercase(),
            p,
            r: precision.c_type(),
            m: match precision {
                Precision::Float => "f",
                Precision::Double => "",
            },
        }
    }
}

/// The fields of the coefficient struct, in order.
fn fields(plan: &Plan) -> Vec<Field> {
    let mut out = Vec::new();
    match &plan.accel {
        AccelPlan::Physical(p) => physical_fields(&mut out, p),
        AccelPlan::Linear(l) => linear_fields(&mut out, l),
        AccelPlan::Static(s) => static_fields(&mut out, s),
        AccelPlan::Ann(n) => network_fields(&mut out, n),
        AccelPlan::PhysicalAnn(pa) => {
            let (p, n, c) = (&pa.0, &pa.1, &pa.2);
            physical_fields(&mut out, p);
            network_fields(&mut out, n);
            coverage_fields(&mut out, c);
        }
        AccelPlan::AsRead => {}
    }
    if let Some(covariance) = &plan.covariance {
        let (name, order) = covariance_field(plan);
        out.push(real(
            name,
            &[12, 12],
            covariance.iter().flatten().copied().collect(),
            &format!("Sigma: the 12 parameters' covariance ({order}), for the predicted sd"),
        ));
    }
    if let Some(g) = &plan.gyro {
        gyro_fields(&mut out, g);
    }
    out
}

/// The covariance's C field and its parameters' order, by the kind that carries it.
fn covariance_field(plan: &Plan) -> (&'static str, &'static str) {
    match plan.accel {
        AccelPlan::Linear(_) => ("lin_covariance", "offsets, then the matrix row by row"),
        _ => ("phys_covariance", "b, s, m, q order"),
    }
}

/// The inverse sensor model's bias, scale, misalignment, quadratic term and training range.
fn physical_fields(out: &mut Vec<Field>, p: &PhysicalPlan) {
    out.push(real("phys_bias", &[3], p.bias.to_vec(), "b, m/s^2"));
    out.push(real(
        "phys_one_plus_scale",
        &[3],
        p.one_plus_scale.to_vec(),
        "1 + s",
    ));
    out.push(real(
        "phys_misalignment",
        &[3],
        p.misalignment.to_vec(),
        "m_yx, m_zx, m_zy, rad",
    ));
    if !p.is_linear() {
        out.push(real("phys_quadratic", &[3], p.quadratic.to_vec(), "q, 1/(m/s^2)"));
    }
    out.push(real(
        "phys_lower",
        &[3],
        p.lower.to_vec(),
        "readings below are outside the training range (10 % margin)",
    ));
    out.push(real("phys_upper", &[3], p.upper.to_vec(), "and above"));
}

/// The network's weights and its input and output scalings.
fn network_fields(out: &mut Vec<Field>, n: &NetworkPlan) {
    out.push(real(
        "net_weights",
        &[n.weights.len()],
        n.weights.clone(),
        "per layer: weight matrix row-major (unit x input), then biases",
    ));
    let k = n.axes.len();
    out.push(real(
        "net_input_gain",
        &[k],
        n.input_gain.clone(),
        "scaled = gain * x + offset",
    ));
    out.push(real("net_input_offset", &[k], n.input_offset.clone(), ""));
    out.push(real(
        "net_output_min",
        &[k],
        n.output_min.clone(),
        "x = min + (scaled + 1) * span / 2",
    ));
    out.push(real("net_output_span", &[k], n.output_span.clone(), ""));
    out.push(real(
        "net_output_gain",
        &[k],
        n.output_gain.clone(),
        "the output scaling's forward map",
    ));
    out.push(real("net_output_offset", &[k], n.output_offset.clone(), ""));
}

/// The linear corrector's offset and matrix.
fn linear_fields(out: &mut Vec<Field>, l: &LinearPlan) {
    let k = l.axes.len();
    out.push(real("lin_offset", &[k], l.offset.clone(), "m/s^2"));
    out.push(real(
        "lin_matrix",
        &[k, k],
        l.matrix.iter().flatten().copied().collect(),
        "row i: the corrected axes' weights in corrected axis i",
    ));
}

/// The still-pose calibration's bias, scale, nonlinearity and misalignment matrix.
fn static_fields(out: &mut Vec<Field>, s: &StaticPlan) {
    out.push(real("st_bias", &[3], s.bias.to_vec(), "b, input units"));
    out.push(real(
        "st_scale",
        &[3],
        s.scale.to_vec(),
        "s, m/s^2 per input unit",
    ));
    out.push(real(
        "st_nonlinearity",
        &[3],
        s.nonlinearity.to_vec(),
        "q, 1/(m/s^2)",
    ));
    out.push(real(
        "st_matrix",
        &[3, 3],
        s.matrix.iter().flatten().copied().collect(),
        "T, misalignment",
    ));
}

/// The coverage box and the bit set of its covered cells.
fn coverage_fields(out: &mut Vec<Field>, c: &CoveragePlan) {
    out.push(real(
        "cov_lower",
        &[3],
        c.lower.to_vec(),
        "the coverage box, m/s^2",
    ));
    out.push(real("cov_width", &[3], c.width.to_vec(), ""));
    out.push(Field {
        name: "cov_covered".into(),
        dims: vec![c.bits.len()],
        values: Values::Bytes(c.bits.clone()),
        doc: "bit c % 8 of byte c / 8: cell c = x + cells * (y + cells * z) covered".into(),
    });
}

/// The gyro model's bias and inverse sensitivity.
fn gyro_fields(out: &mut Vec<Field>, g: &GyroPlan) {
    out.push(real(
        "gyro_bias",
        &[3],
        g.bias.to_vec(),
        "b, the gyro's input unit",
    ));
    out.push(real(
        "gyro_inverse",
        &[3, 3],
        g.inverse.iter().flatten().copied().collect(),
        "K^-1",
    ));
}

fn initializer(field: &Field, precision: Precision) -> String {
    let items: Vec<String> = match &field.values {
        Values::Real(v) => v.iter().map(|&x| literal(x, precision)).collect(),
        Values::Bytes(b) => b.iter().map(|x| format!("0x{x:02x}")).collect(),
    };
    let per_row = *field.dims.last().unwrap_or(&1);
    let wide = per_row > 8;
    let mut rows: Vec<String> = items
        .chunks(per_row.max(1))
        .map(|c| {
            if wide {
                // A wide matrix's row wrapped six values to a line.
                let lines: Vec<String> = c.chunks(6).map(|l| l.join(", ")).collect();
                lines.join(",\n         ")
            } else {
                c.join(", ")
            }
        })
        .collect();
    if field.dims.len() == 2 {
        rows = rows.into_iter().map(|r| format!("{{{r}}}")).collect();
    }
    // Long arrays wrapped eight values to a line, wide matrices a row (or more) to a line.
    let text = if field.dims.len() == 2 && wide {
        rows.join(",\n        ")
    } else if field.dims.len() == 1 && items.len() > 8 {
        items
            .chunks(8)
            .map(|c| c.join(", "))
            .collect::<Vec<_>>()
            .join(",\n        ")
    } else {
        rows.join(", ")
    };
    format!("{{{text}}}")
}

/// The first coefficient that `precision` cannot hold as a finite number (a weight of 1e308 is
/// `inff` in float, which C reads as infinity and no correction survives): its C field with its
/// index (`net_weights[3]`, `st_matrix[1][2]`) and its value.
pub(crate) fn unwritable(plan: &Plan, precision: Precision) -> Option<(String, f64)> {
    let finite = |x: f64| match precision {
        Precision::Double => x.is_finite(),
        Precision::Float => (x as f32).is_finite(),
    };
    fields(plan).into_iter().find_map(|f| {
        let Values::Real(values) = &f.values else {
            return None;
        };
        let i = values.iter().position(|&x| !finite(x))?;
        let index = match f.dims[..] {
            [_, columns] => format!("[{}][{}]", i / columns, i % columns),
            _ => format!("[{i}]"),
        };
        Some((format!("{}{index}", f.name), values[i]))
    })
}

/// Header and source of one precision: `(header file name, header, source file name, source)`.
pub(crate) fn files(
    plan: &Plan,
    name: &str,
    precision: Precision,
    provenance: &str,
) -> [(String, String); 2] {
    let n = Names::new(name, precision);
    let fields = fields(plan);
    let header = header(plan, &n, &fields, precision, provenance);
    let source = source(plan, &n, &fields, precision, provenance);
    [(format!("{}.h", n.p), header), (format!("{}.c", n.p), source)]
}

fn header(plan: &Plan, n: &Names, fields: &[Field], precision: Precision, provenance: &str) -> String {
    let (p, u, r) = (&n.p, &n.u, n.r);
    let mut h = String::new();
    let _ = writeln!(
        h,
        "/* {p}.h: the spincal corrector \"{}\" in {r}, {provenance}.\n \
         * C99; no dynamic memory; nothing beyond <math.h> and the freestanding <stdint.h>.\n \
         * Compile without contraction of multiply-adds (-ffp-contract=off, the default of\n \
         * -std=c99) to repeat spincal's arithmetic. Generated: edit the model, not this file. */",
        plan.kind
    );
    let _ = writeln!(h, "#ifndef {u}_H\n#define {u}_H\n");
    let _ = writeln!(
        h,
        "/* Values of the stream's delay history (a network's scaled inputs; 1 when there is none). */\n\
         #define {u}_HISTORY {}\n\
         /* Bits of the value {p}_correct returns. */\n\
         #define {u}_VALID 1u   /* the sample was corrected (else accel_out is the reading) */\n\
         #define {u}_OUTSIDE 2u /* an input lay beyond the training range */\n\
         #define {u}_GYRO 4u    /* gyro_out holds the corrected rate */\n",
        plan.history().max(1)
    );
    let _ = writeln!(h, "typedef struct {p}_coefficients {{");
    for f in fields {
        let ty = match f.values {
            Values::Real(_) => r,
            Values::Bytes(_) => "unsigned char",
        };
        let dims: String = f.dims.iter().map(|d| format!("[{d}]")).collect();
        if f.doc.is_empty() {
            let _ = writeln!(h, "    {ty} {}{dims};", f.name);
        } else {
            let _ = writeln!(h, "    {ty} {}{dims}; /* {} */", f.name, f.doc);
        }
    }
    if fields.is_empty() {
        let _ = writeln!(h, "    char unused;");
    }
    let _ = writeln!(h, "}} {p}_coefficients;\n");
    let _ = writeln!(
        h,
        "/* One stream's state: start it with {p}_init, then pass every sample in time order. */\n\
         typedef struct {p}_state {{\n    {r} history[{u}_HISTORY];\n    unsigned long seen;\n}} {p}_state;\n"
    );
    let _ = writeln!(
        h,
        "/* The exported model's coefficients. */\nextern const {p}_coefficients {p}_model;\n"
    );
    let _ = writeln!(h, "void {p}_init({p}_state *state);\n");
    let gyro_doc = if plan.gyro.is_some() {
        "gyro: the gyroscope's reading in its calibrated input unit (rad/s or counts), or 0;\n \
         * gyro_out: its rate in rad/s (with the GYRO bit), or 0."
    } else {
        "gyro, gyro_out: unused (this model calibrates no gyroscope); pass 0."
    };
    let _ = writeln!(
        h,
        "/* Corrects one sample. accel: sensor frame, m/s^2 (a static calibration's raw unit for\n \
         * \"static\"); accel_out: the corrected acceleration, m/s^2 (axes the model does not\n \
         * correct pass through; the reading itself when VALID is not set). {gyro_doc}\n \
         * Returns VALID | OUTSIDE | GYRO bits. accel and accel_out may be the same array. */\n\
         unsigned {p}_correct(const {p}_coefficients *c, {p}_state *state, const {r} accel[3],\n\
         \x20   const {r} *gyro, {r} accel_out[3], {r} *gyro_out);\n"
    );
    let _ = precision;
    predicted_sd_decl(&mut h, plan, n);
    let _ = writeln!(h, "#endif");
    h
}

fn source(plan: &Plan, n: &Names, fields: &[Field], precision: Precision, provenance: &str) -> String {
    let (p, u, r) = (&n.p, &n.u, n.r);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "/* {p}.c: the spincal corrector \"{}\" in {r}, {provenance}. */",
        plan.kind
    );
    let _ = writeln!(s, "#include <math.h>");
    if matches!(plan.accel, AccelPlan::Ann(_) | AccelPlan::PhysicalAnn(..)) {
        let _ = writeln!(s, "#include <stdint.h>");
    }
    let _ = writeln!(s, "#include \"{p}.h\"\n");
    let _ = writeln!(s, "const {p}_coefficients {p}_model = {{");
    for f in fields {
        let _ = writeln!(s, "    {},", initializer(f, precision));
    }
    if fields.is_empty() {
        let _ = writeln!(s, "    0");
    }
    let _ = writeln!(s, "}};\n");
    let _ = writeln!(
        s,
        "void {p}_init({p}_state *state)\n{{\n    int i;\n    for (i = 0; i < {u}_HISTORY; ++i) {{\n        state->history[i] = 0;\n    }}\n    state->seen = 0;\n}}\n"
    );
    match &plan.accel {
        AccelPlan::Physical(ph) => {
            physical_fn(&mut s, n, ph, true);
        }
        AccelPlan::Linear(l) => linear_fn(&mut s, n, l),
        AccelPlan::Static(st) => static_fn(&mut s, n, st),
        AccelPlan::Ann(net) => {
            tanh_fn(&mut s, n, precision);
            forward_fn(&mut s, n, net);
            ann_fn(&mut s, n, net);
        }
        AccelPlan::PhysicalAnn(pa) => {
            let (ph, net, cov) = (&pa.0, &pa.1, &pa.2);
            physical_fn(&mut s, n, ph, false);
            tanh_fn(&mut s, n, precision);
            forward_fn(&mut s, n, net);
            coverage_fn(&mut s, n, cov);
            physical_ann_fn(&mut s, n, net);
        }
        AccelPlan::AsRead => as_read_fn(&mut s, n),
    }
    match (&plan.covariance, &plan.accel) {
        (Some(_), AccelPlan::Physical(ph)) => predicted_sd_fn(&mut s, n, ph, precision),
        (Some(_), AccelPlan::Linear(_)) => linear_predicted_sd_fn(&mut s, n),
        _ => {}
    }
    correct_fn(&mut s, n, plan.gyro.as_ref());
    s
}

/// The header's part on the error bar: `P_predicted_sd`'s declaration, or why there is none.
fn predicted_sd_decl(h: &mut String, plan: &Plan, n: &Names) {
    let (p, u, r) = (&n.p, &n.u, n.r);
    if plan.covariance.is_some() {
        let _ = writeln!(
            h,
            "/* 1: the model carries its parameters' covariance, and {p}_predicted_sd gives each\n \
             * sample's error bar as spincal correct does. */\n\
             #define {u}_PREDICTS_SD 1\n\
             /* Bits of the value {p}_predicted_sd returns (apart from the others, so all fit one word). */\n\
             #define {u}_SD 8u      /* sd holds the correction's predicted standard deviations */\n\
             #define {u}_BETTER 16u /* on every axis predicted to beat no correction (predicted_better) */\n\n\
             /* The standard deviation per axis (m/s^2) of the correction of accel that the parameters'\n \
             * covariance predicts, sqrt(diag(J Sigma J^T)) with J the correction's derivatives by the 12\n \
             * parameters (spincal correct's <column>_corrected_sd), into sd. Returns SD | BETTER, BETTER\n \
             * where on every axis the correction c = accel_out - accel has c^2 > 2 sd^2 (predicted to beat\n \
             * no correction: spincal correct's predicted_better); 0 with sd zero where VALID is unset\n \
             * (spincal correct leaves both empty there). Needs no state; accel and sd may be the same array. */\n\
             unsigned {p}_predicted_sd(const {p}_coefficients *c, const {r} accel[3], {r} sd[3]);\n"
        );
    } else {
        let why = plan.no_error_bar().unwrap_or_default();
        let _ = writeln!(
            h,
            "/* 0: no {p}_predicted_sd: {}; spincal correct\n \
             * writes no <column>_corrected_sd or predicted_better for it either. */\n\
             #define {u}_PREDICTS_SD 0\n",
            super::wrap_words(why, "\n * ")
        );
    }
}

/// `unsigned P_predicted_sd(c, accel, sd)`: the correction's Jacobian by spincal's
/// `SensorModel::correct_with_jacobian` operations, √diag(J Σ Jᵀ) by `propagated_variance`'s,
/// and the flag of `predicted_to_help`.
fn predicted_sd_fn(s: &mut String, n: &Names, ph: &PhysicalPlan, precision: Precision) {
    let (p, u, r, m) = (&n.p, &n.u, n.r, n.m);
    let epsilon = match precision {
        Precision::Float => format!("{:?}f", f32::EPSILON),
        Precision::Double => format!("{:?}", f64::EPSILON),
    };
    let quadratic = if ph.is_linear() {
        // q = 0: the slope 1 + 2 q u is 1, and dividing by it changes no bit.
        "        jac[k][9 + k] = -u * u / d; /* q = 0: the slope 1 + 2 q u is 1 */\n".to_string()
    } else {
        format!(
            "        /* q u^2 + u = m, so du/dq = -u^2 / (1 + 2 q u). */\n\
             \x20       slope = 1 + 2 * c->phys_quadratic[k] * u;\n\
             \x20       if (fabs{m}(slope) < {epsilon}) {{\n            sd[0] = 0;\n            sd[1] = 0;\n            sd[2] = 0;\n            return 0;\n        }}\n\
             \x20       jac[k][9 + k] = -u * u / slope / d;\n"
        )
    };
    let slope_decl = if ph.is_linear() {
        String::new()
    } else {
        format!("    {r} slope;\n")
    };
    let _ = writeln!(
        s,
        "/* spincal correct's error bar and predicted_better (see the header). */\n\
         unsigned {p}_predicted_sd(const {p}_coefficients *c, const {r} accel[3], {r} sd[3])\n{{\n    \
         {r} m[3], f[3], v[3], jac[3][12];\n{slope_decl}    int k, j, a, b;\n    unsigned flags = {u}_SD | {u}_BETTER;\n    \
         m[0] = accel[0];\n    m[1] = accel[1];\n    m[2] = accel[2];\n    \
         if (!({p}_physical(c, m, f) & {u}_VALID)) {{\n        sd[0] = 0;\n        sd[1] = 0;\n        sd[2] = 0;\n        return 0;\n    }}\n    \
         /* v = (I + M) f: the force as the three skewed axes see it. */\n    \
         v[0] = f[0];\n    v[1] = f[1] + c->phys_misalignment[0] * f[0];\n    \
         v[2] = f[2] + c->phys_misalignment[1] * f[0] + c->phys_misalignment[2] * f[1];\n    \
         /* dv/dtheta for v = (u - b) / (1 + s), u the inverse of m: b, s and q act on their own axis. */\n    \
         for (k = 0; k < 3; ++k) {{\n        for (j = 0; j < 12; ++j) {{\n            jac[k][j] = 0;\n        }}\n    }}\n    \
         for (k = 0; k < 3; ++k) {{\n        \
         const {r} d = c->phys_one_plus_scale[k];\n        \
         const {r} u = c->phys_bias[k] + d * v[k];\n{quadratic}        \
         jac[k][k] = -1 / d;\n        jac[k][3 + k] = -v[k] / d;\n    }}\n    \
         /* f = (I + M)^-1 v: forward substitution carries v's derivatives; M's own enter directly. */\n    \
         for (j = 0; j < 12; ++j) {{\n        \
         jac[1][j] = jac[1][j] - c->phys_misalignment[0] * jac[0][j];\n        \
         jac[2][j] = jac[2][j] - c->phys_misalignment[1] * jac[0][j] - c->phys_misalignment[2] * jac[1][j];\n    }}\n    \
         jac[1][6] -= f[0];\n    jac[2][6] += c->phys_misalignment[2] * f[0];\n    jac[2][7] -= f[0];\n    jac[2][8] -= f[1];\n    \
         {}",
        error_bar_loop(n, "phys_covariance")
    );
}

/// The end of `P_predicted_sd`: √diag(J Σ Jᵀ) from `jac`, skipping the parameters a row does not
/// depend on, in `propagated_variance`'s order, and the flag of `predicted_to_help` from the
/// correction `f - m`. One text for every kind.
fn error_bar_loop(n: &Names, covariance: &str) -> String {
    let (u, r, m) = (&n.u, n.r, n.m);
    format!(
        "/* diag(J Sigma J^T), skipping the parameters a row does not depend on (as spincal). */\n    \
         for (k = 0; k < 3; ++k) {{\n        {r} sum = 0, correction;\n        \
         for (a = 0; a < 12; ++a) {{\n            {r} inner = 0;\n            \
         if (jac[k][a] == 0) {{\n                continue;\n            }}\n            \
         for (b = 0; b < 12; ++b) {{\n                inner += c->{covariance}[a][b] * jac[k][b];\n            }}\n            \
         sum += jac[k][a] * inner;\n        }}\n        \
         sd[k] = sqrt{m}(sum > 0 ? sum : 0);\n        \
         /* Predicted to help when c^2 > 2 sd^2: c^2 - sd^2 estimates the true correction's square,\n         \
         * and applying c leaves sd^2. */\n        \
         correction = f[k] - m[k];\n        \
         if (!(correction * correction > 2 * sd[k] * sd[k])) {{\n            flags &= ~{u}_BETTER;\n        }}\n    }}\n    \
         return flags;\n}}\n"
    )
}

/// `unsigned P_predicted_sd(c, accel, sd)` of a linear map of the three axes: the map's
/// Jacobian by its 12 parameters (∂f_i/∂c_i = 1, ∂f_i/∂A_ij = m_j, `LinearModel::
/// correct_with_jacobian`), then the loop every kind shares.
fn linear_predicted_sd_fn(s: &mut String, n: &Names) {
    let (p, u, r) = (&n.p, &n.u, n.r);
    let _ = writeln!(
        s,
        "/* spincal correct's error bar and predicted_better (see the header). */\n\
         unsigned {p}_predicted_sd(const {p}_coefficients *c, const {r} accel[3], {r} sd[3])\n{{\n    \
         {r} m[3], f[3], jac[3][12];\n    int k, j, a, b;\n    unsigned flags = {u}_SD | {u}_BETTER;\n    \
         m[0] = accel[0];\n    m[1] = accel[1];\n    m[2] = accel[2];\n    \
         (void){p}_accel(c, 0, m, f);\n    \
         /* df_i/dc_i = 1, df_i/dA_ij = m_j: offsets first, then the matrix row by row. */\n    \
         for (k = 0; k < 3; ++k) {{\n        for (j = 0; j < 12; ++j) {{\n            jac[k][j] = 0;\n        }}\n        \
         jac[k][k] = 1;\n        for (j = 0; j < 3; ++j) {{\n            jac[k][3 + 3 * k + j] = m[j];\n        }}\n    }}\n    \
         {}",
        error_bar_loop(n, "lin_covariance")
    );
}

/// `static unsigned P_physical(c, m, f)`: the inverse sensor model, VALID | OUTSIDE bits.
fn physical_fn(s: &mut String, n: &Names, ph: &PhysicalPlan, with_accel: bool) {
    let (p, u, r, m) = (&n.p, &n.u, n.r, n.m);
    let body = if ph.is_linear() {
        // q = 0: the library's root 2m / (1 + sqrt(1 + 4·0·m)) is m exactly.
        format!("        const {r} u = m[k];\n")
    } else {
        format!(
            "        /* The root of q u^2 + u - m = 0 nearest u = m, without cancellation. */\n\
             \x20       const {r} disc = 1 + 4 * c->phys_quadratic[k] * m[k];\n\
             \x20       {r} u;\n\
             \x20       if (disc <= 0) {{\n            return 0;\n        }}\n\
             \x20       u = 2 * m[k] / (1 + sqrt{m}(disc));\n"
        )
    };
    let _ = writeln!(
        s,
        "/* The inverse of the sensor model; 0 beyond the quadratic's turning point. */\n\
         static unsigned {p}_physical(const {p}_coefficients *c, const {r} m[3], {r} f[3])\n{{\n    \
         {r} v[3];\n    int k;\n    unsigned flags = {u}_VALID;\n    \
         for (k = 0; k < 3; ++k) {{\n{body}        v[k] = (u - c->phys_bias[k]) / c->phys_one_plus_scale[k];\n    }}\n    \
         f[0] = v[0];\n    f[1] = v[1] - c->phys_misalignment[0] * f[0];\n    \
         f[2] = v[2] - c->phys_misalignment[1] * f[0] - c->phys_misalignment[2] * f[1];\n    \
         if (!(isfinite(f[0]) && isfinite(f[1]) && isfinite(f[2]))) {{\n        return 0;\n    }}\n    \
         for (k = 0; k < 3; ++k) {{\n        if (m[k] < c->phys_lower[k] || m[k] > c->phys_upper[k]) {{\n            flags |= {u}_OUTSIDE;\n        }}\n    }}\n    \
         return flags;\n}}\n"
    );
    if !with_accel {
        return;
    }
    let _ = writeln!(
        s,
        "static unsigned {p}_accel(const {p}_coefficients *c, {p}_state *state, const {r} m[3], {r} out[3])\n{{\n    \
         unsigned flags;\n    (void)state;\n    flags = {p}_physical(c, m, out);\n    \
         if (!(flags & {u}_VALID)) {{\n        out[0] = m[0];\n        out[1] = m[1];\n        out[2] = m[2];\n        return {u}_OUTSIDE;\n    }}\n    \
         return flags;\n}}\n"
    );
}

fn linear_fn(s: &mut String, n: &Names, l: &LinearPlan) {
    let (p, u, r) = (&n.p, &n.u, n.r);
    let mut body = String::new();
    for (i, &axis) in l.axes.iter().enumerate() {
        let terms: String = l
            .axes
            .iter()
            .enumerate()
            .map(|(j, &from)| format!(" + c->lin_matrix[{i}][{j}] * m[{from}]"))
            .collect();
        let _ = writeln!(body, "    out[{axis}] = c->lin_offset[{i}]{terms};");
    }
    let _ = writeln!(
        s,
        "static unsigned {p}_accel(const {p}_coefficients *c, {p}_state *state, const {r} m[3], {r} out[3])\n{{\n    \
         (void)state;\n    out[0] = m[0];\n    out[1] = m[1];\n    out[2] = m[2];\n{body}    return {u}_VALID;\n}}\n"
    );
}

/// The accelerometer as read (a file that corrects the gyroscope alone): `spincal correct`
/// writes no corrected accelerometer column for it, so the reading is the sample's value.
fn as_read_fn(s: &mut String, n: &Names) {
    let (p, u, r) = (&n.p, &n.u, n.r);
    let _ = writeln!(
        s,
        "/* The accelerometer as read: this model corrects only the gyroscope. */\n\
         static unsigned {p}_accel(const {p}_coefficients *c, {p}_state *state, const {r} m[3], {r} out[3])\n{{\n    \
         (void)c;\n    (void)state;\n    out[0] = m[0];\n    out[1] = m[1];\n    out[2] = m[2];\n    return {u}_VALID;\n}}\n"
    );
}

fn static_fn(s: &mut String, n: &Names, _st: &StaticPlan) {
    let (p, u, r) = (&n.p, &n.u, n.r);
    let _ = writeln!(
        s,
        "static unsigned {p}_accel(const {p}_coefficients *c, {p}_state *state, const {r} m[3], {r} out[3])\n{{\n    \
         {r} v[3];\n    int i;\n    (void)state;\n    \
         for (i = 0; i < 3; ++i) {{\n        const {r} u = c->st_scale[i] * (m[i] - c->st_bias[i]);\n        v[i] = u + c->st_nonlinearity[i] * u * u;\n    }}\n    \
         for (i = 0; i < 3; ++i) {{\n        out[i] = c->st_matrix[i][0] * v[0] + c->st_matrix[i][1] * v[1] + c->st_matrix[i][2] * v[2];\n    }}\n    \
         return {u}_VALID;\n}}\n"
    );
}

/// The tanh of spincal's network (see `spincal_embedded::tanh_f64` / `tanh_f32`).
fn tanh_fn(s: &mut String, n: &Names, precision: Precision) {
    let (p, r, m) = (&n.p, n.r, n.m);
    let lit = |x: f64| literal(x, precision);
    match precision {
        Precision::Double => {
            let c: Vec<String> = super::TANH_C.iter().map(|&x| lit(x)).collect();
            let _ =
                writeln!(
                s,
                "/* tanh(|x|) = -u / (2 + u), u = expm1(-2|x|): expm1 by reduction to |r| <= ln2/2 and a\n \
                 * degree-13 Taylor polynomial (Estrin); spincal's operations, within 4 ulps of tanh. */\n\
                 static double {p}_tanh(double x)\n{{\n    \
                 static const double t[12] = {{\n        {}\n    }};\n    \
                 const double magnitude = fabs(x);\n    \
                 const double y = -2.0 * (magnitude > 20.0 ? 20.0 : magnitude);\n    \
                 const double shifted = y * {} + {};\n    \
                 const double k = shifted - {};\n    \
                 const double r = (y - k * {}) - k * {};\n    \
                 const double r2 = r * r;\n    const double r4 = r2 * r2;\n    \
                 const double p0 = t[0] + t[1] * r, p2 = t[2] + t[3] * r, p4 = t[4] + t[5] * r;\n    \
                 const double p6 = t[6] + t[7] * r, p8 = t[8] + t[9] * r, p10 = t[10] + t[11] * r;\n    \
                 const double low = (p0 + p2 * r2) + (p4 + p6 * r2) * r4;\n    \
                 const double high = p8 + p10 * r2;\n    \
                 const double poly = low + high * (r4 * r4);\n    \
                 const double expm1_r = r + r2 * poly;\n    \
                 union {{\n        double d;\n        uint64_t u;\n    }} bits, scale;\n    \
                 double u;\n    \
                 bits.d = shifted;\n    \
                 scale.u = (bits.u - UINT64_C(0x{:016x}) + 1023u) << 52;\n    \
                 u = scale.d * expm1_r + (scale.d - 1.0);\n    \
                 return copysign(-u / (2.0 + u), x);\n}}\n",
                c.chunks(4).map(|c| c.join(", ")).collect::<Vec<_>>().join(",\n        "),
                lit(std::f64::consts::LOG2_E),
                lit(super::ROUNDER),
                lit(super::ROUNDER),
                lit(super::LN2_HI),
                lit(super::LN2_LO),
                super::ROUNDER.to_bits(),
            );
        }
        Precision::Float => {
            let c: Vec<String> = super::TANH_C_F.iter().map(|&x| format!("{x:?}f")).collect();
            let _ = writeln!(
                s,
                "/* tanh(|x|) = -u / (2 + u), u = expm1(-2|x|): expm1 by reduction to |r| <= ln2/2 and a\n \
                 * degree-8 Taylor polynomial (Horner); within 2 ulps of tanh over [-20, 20] (measured every 1/4096). */\n\
                 static float {p}_tanh(float x)\n{{\n    \
                 const float magnitude = fabs{m}(x);\n    \
                 const float y = -2.0f * (magnitude > 20.0f ? 20.0f : magnitude);\n    \
                 const float shifted = y * {:?}f + {:?}f;\n    \
                 const float k = shifted - {:?}f;\n    \
                 const float r = (y - k * {:?}f) - k * {:?}f;\n    \
                 const float poly = {c0} + r * ({c1} + r * ({c2} + r * ({c3} + r * ({c4} + r * ({c5} + r * {c6})))));\n    \
                 const float expm1_r = r + (r * r) * poly;\n    \
                 union {{\n        {r} f;\n        uint32_t u;\n    }} bits, scale;\n    \
                 float u;\n    \
                 bits.f = shifted;\n    \
                 scale.u = (bits.u - UINT32_C(0x{:08x}) + 127u) << 23;\n    \
                 u = scale.f * expm1_r + (scale.f - 1.0f);\n    \
                 return copysign{m}(-u / (2.0f + u), x);\n}}\n",
                std::f32::consts::LOG2_E,
                super::ROUNDER_F,
                super::ROUNDER_F,
                super::LN2_HI_F,
                super::LN2_LO_F,
                super::ROUNDER_F.to_bits(),
                c0 = c[0],
                c1 = c[1],
                c2 = c[2],
                c3 = c[3],
                c4 = c[4],
                c5 = c[5],
                c6 = c[6],
            );
        }
    }
}

/// `static void P_forward(w, input, output)`: the network, one layer after another.
fn forward_fn(s: &mut String, n: &Names, net: &NetworkPlan) {
    let (p, r) = (&n.p, n.r);
    let sizes = &net.sizes;
    let last = sizes.len() - 1;
    let mut body = String::new();
    let mut at = 0;
    for l in 1..=last {
        let (n_in, n_out) = (sizes[l - 1], sizes[l]);
        let biases = at + n_out * n_in;
        let input = if l == 1 {
            "input".to_string()
        } else {
            format!("a{}", l - 1)
        };
        let output = if l == last {
            "output".to_string()
        } else {
            format!("a{l}")
        };
        if l != last {
            let _ = writeln!(body, "    {r} a{l}[{n_out}];");
        }
        let activation = if l == last {
            "z".to_string()
        } else {
            format!("{p}_tanh(z)")
        };
        let _ = writeln!(
            body,
            "    for (i = 0; i < {n_out}; ++i) {{\n        {r} z = w[{biases} + i];\n        \
             for (j = 0; j < {n_in}; ++j) {{\n            z += w[{at} + i * {n_in} + j] * {input}[j];\n        }}\n        \
             {output}[i] = {activation};\n    }}"
        );
        at = biases + n_out;
    }
    // Declarations first (C89-style blocks read the same in every compiler).
    let (decls, loops): (Vec<&str>, Vec<&str>) =
        body.lines().partition(|l| l.starts_with(&format!("    {r} a")));
    let _ = writeln!(
        s,
        "/* The network: tanh hidden layers, a linear output layer ({}). */\n\
         static void {p}_forward(const {r} *w, const {r} *input, {r} *output)\n{{\n{}\n    int i, j;\n{}\n}}\n",
        sizes.iter().map(|x| x.to_string()).collect::<Vec<_>>().join("-"),
        decls.join("\n"),
        loops.join("\n")
    );
}

fn reverse_expr(c: usize, value: &str) -> String {
    format!(
        "(c->net_output_span[{c}] > 0 ? c->net_output_min[{c}] + ({value} + 1) * c->net_output_span[{c}] / 2 : c->net_output_min[{c}])"
    )
}

fn ann_fn(s: &mut String, n: &Names, net: &NetworkPlan) {
    let (p, u, r, m) = (&n.p, &n.u, n.r, n.m);
    let lags = net.delays + 1;
    let limit = literal(
        net.limit,
        if r == "float" {
            Precision::Float
        } else {
            Precision::Double
        },
    );
    let mut shift = String::new();
    for (c, &axis) in net.axes.iter().enumerate() {
        let base = c * lags;
        if lags > 1 {
            let _ = writeln!(
                shift,
                "    for (j = {}; j > 0; --j) {{\n        state->history[{base} + j] = state->history[{base} + j - 1];\n    }}",
                lags - 1
            );
        }
        let _ = writeln!(
            shift,
            "    state->history[{base}] = c->net_input_gain[{c}] * m[{axis}] + c->net_input_offset[{c}];\n    \
             if (fabs{m}(state->history[{base}]) > {limit}) {{\n        flags |= {u}_OUTSIDE;\n    }}"
        );
    }
    let mut outputs = String::new();
    for (c, &axis) in net.axes.iter().enumerate() {
        let _ = writeln!(
            outputs,
            "    out[{axis}] = {};",
            reverse_expr(c, &format!("scaled[{c}]"))
        );
    }
    let j_decl = if lags > 1 { "    int j;\n" } else { "" };
    let _ = writeln!(
        s,
        "static unsigned {p}_accel(const {p}_coefficients *c, {p}_state *state, const {r} m[3], {r} out[3])\n{{\n    \
         {r} scaled[{k}];\n    unsigned flags = 0;\n{j_decl}    \
         out[0] = m[0];\n    out[1] = m[1];\n    out[2] = m[2];\n{shift}    \
         if (state->seen <= {delays}ul) {{\n        ++state->seen;\n    }}\n    \
         if (state->seen <= {delays}ul || (flags & {u}_OUTSIDE)) {{\n        return flags;\n    }}\n    \
         {p}_forward(c->net_weights, state->history, scaled);\n{outputs}    \
         return flags | {u}_VALID;\n}}\n",
        k = net.axes.len(),
        delays = net.delays,
    );
}

fn coverage_fn(s: &mut String, n: &Names, cov: &CoveragePlan) {
    let (p, r) = (&n.p, n.r);
    let cells = cov.cells;
    let _ = writeln!(
        s,
        "/* Whether v lies in a cell of the box that training reached. */\n\
         static int {p}_covers(const {p}_coefficients *c, const {r} v[3])\n{{\n    \
         unsigned index[3], cell;\n    int k;\n    \
         for (k = 0; k < 3; ++k) {{\n        const {r} u = (v[k] - c->cov_lower[k]) / c->cov_width[k];\n        \
         if (!(u >= 0 && u <= 1)) {{\n            return 0;\n        }}\n        \
         index[k] = (unsigned)(u * {cells});\n        if (index[k] > {last}u) {{\n            index[k] = {last}u;\n        }}\n    }}\n    \
         cell = index[0] + {cells}u * (index[1] + {cells}u * index[2]);\n    \
         return (c->cov_covered[cell / 8u] >> (cell % 8u)) & 1u;\n}}\n",
        last = cells - 1
    );
}

fn physical_ann_fn(s: &mut String, n: &Names, net: &NetworkPlan) {
    let (p, u, r, m) = (&n.p, &n.u, n.r, n.m);
    let limit = literal(
        net.limit,
        if r == "float" {
            Precision::Float
        } else {
            Precision::Double
        },
    );
    let _ = writeln!(
        s,
        "/* The physical correction, then the network's residual where it is trusted: inside its\n \
         * training range, in a covered cell, and with an output within its trained range. */\n\
         static unsigned {p}_accel(const {p}_coefficients *c, {p}_state *state, const {r} m[3], {r} out[3])\n{{\n    \
         {r} f[3], scaled[3], residual[3];\n    unsigned flags;\n    int k, trusted = 1;\n    \
         flags = {p}_physical(c, m, f);\n    \
         if (!(flags & {u}_VALID)) {{\n        out[0] = m[0];\n        out[1] = m[1];\n        out[2] = m[2];\n        return {u}_OUTSIDE;\n    }}\n    \
         for (k = 0; k < 3; ++k) {{\n        state->history[k] = c->net_input_gain[k] * f[k] + c->net_input_offset[k];\n        \
         if (fabs{m}(state->history[k]) > {limit}) {{\n            trusted = 0;\n        }}\n    }}\n    \
         {p}_forward(c->net_weights, state->history, scaled);\n    \
         for (k = 0; k < 3; ++k) {{\n        residual[k] = {rev};\n        \
         if (!(fabs{m}(c->net_output_gain[k] * residual[k] + c->net_output_offset[k]) <= {limit})) {{\n            trusted = 0;\n        }}\n    }}\n    \
         if (!trusted || !{p}_covers(c, f)) {{\n        out[0] = f[0];\n        out[1] = f[1];\n        out[2] = f[2];\n        return flags | {u}_OUTSIDE;\n    }}\n    \
         for (k = 0; k < 3; ++k) {{\n        out[k] = f[k] + residual[k];\n    }}\n    \
         return flags;\n}}\n",
        rev = reverse_expr_k("scaled[k]"),
    );
}

fn reverse_expr_k(value: &str) -> String {
    format!(
        "c->net_output_span[k] > 0 ? c->net_output_min[k] + ({value} + 1) * c->net_output_span[k] / 2 : c->net_output_min[k]"
    )
}

fn correct_fn(s: &mut String, n: &Names, gyro: Option<&GyroPlan>) {
    let (p, u, r) = (&n.p, &n.u, n.r);
    let gyro_part = match gyro {
        Some(_) => format!(
            "    if (gyro != 0 && gyro_out != 0) {{\n        \
             const {r} d0 = gyro[0] - c->gyro_bias[0], d1 = gyro[1] - c->gyro_bias[1], d2 = gyro[2] - c->gyro_bias[2];\n        \
             int i;\n        \
             for (i = 0; i < 3; ++i) {{\n            gyro_out[i] = c->gyro_inverse[i][0] * d0 + c->gyro_inverse[i][1] * d1 + c->gyro_inverse[i][2] * d2;\n        }}\n        \
             flags |= {u}_GYRO;\n    }}\n"
        ),
        None => "    (void)gyro;\n    (void)gyro_out;\n".to_string(),
    };
    let _ = writeln!(
        s,
        "unsigned {p}_correct(const {p}_coefficients *c, {p}_state *state, const {r} accel[3],\n\
         \x20   const {r} *gyro, {r} accel_out[3], {r} *gyro_out)\n{{\n    \
         {r} m[3];\n    unsigned flags;\n    \
         m[0] = accel[0];\n    m[1] = accel[1];\n    m[2] = accel[2];\n    \
         flags = {p}_accel(c, state, m, accel_out);\n{gyro_part}    return flags;\n}}"
    );
}
