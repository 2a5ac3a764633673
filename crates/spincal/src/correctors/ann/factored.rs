//! JᵀJ and Jᵀe of a layered network from Kronecker factors, without forming J.
//!
//! The derivative of output o by the weight from input j to unit i of layer l is
//! δ(l, o, i)·ã(l−1, j): the unit's sensitivity (1 or 0 for the linear output layer) times its
//! input (1 for a bias). So the block of JᵀJ between layers l ≥ m is
//!
//!   G[(i, j), (k, q)] = Σ_s D(s)[(i, k)] · A(s)[(j, q)],
//!   D(s)[(i, k)] = Σ_o δ(l, o, i) δ(m, o, k),   A(s)[(j, q)] = ã(l−1, j) ã(m−1, q),
//!
//! a product of two small factor matrices over the samples: one multiply-add per entry and
//! sample, where the Jacobian's rows take one per entry, sample *and output*. Within a layer
//! (l = m) both factors are symmetric, so only i ≥ k and j ≥ q are formed, a quarter of the block.
//! Jᵀe is the same with e_o in place of δ(m, o, k) and 1 for ã(m−1, q). For a 2-[10, 6]-2
//! network that is 2.1 times fewer multiply-adds than JᵀJ over the rows of J.
//!
//! [`FactoredPlan`] lists, for one layout, every factor column as a sum of products of block
//! values, the products to take ([`gram::AddProduct`], padded to whole tiles), and where each
//! entry of JᵀJ's lower triangle and of Jᵀe lies among their sums. The products read one block
//! buffer ([`BlockColumns`]): a zero and a ones column, the forward pass, the sensitivities and
//! the errors where the passes wrote them, then the factor columns formed for the product at
//! hand. A factor column that is one of those values (a product with a bias input or a linear
//! output's sensitivity: about a quarter of them) is read where it is, not copied.

use super::gram;
use super::network::Layout;

/// A value of a block that factor columns multiply: one sample after another.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Source {
    One,
    /// Output `output`'s sensitivity to hidden unit `unit` (counted over all hidden layers).
    Sensitivity {
        output: usize,
        unit: usize,
    },
    /// Row `at` of the forward pass's activations (an input or a hidden unit's value).
    Activation {
        at: usize,
    },
    /// Output `output`'s error.
    Error {
        output: usize,
    },
}

/// Where each kind of value sits in one block's buffer, in columns of the block's sample count.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BlockColumns {
    /// Column 0 is zero (the padding of the products), column 1 is ones.
    pub activations: usize,
    pub sensitivities: usize,
    pub errors: usize,
    /// The first column of the factor columns formed for one product.
    pub formed: usize,
    /// Columns in all, the most any product forms included.
    pub total: usize,
    /// Sensitivity columns per output.
    hidden_units: usize,
}

const ZERO_COLUMN: usize = 0;
const ONES_COLUMN: usize = 1;

impl BlockColumns {
    /// The column that holds `source`'s values.
    #[inline(always)]
    fn of(&self, source: Source) -> usize {
        match source {
            Source::One => ONES_COLUMN,
            Source::Activation { at } => self.activations + at,
            Source::Sensitivity { output, unit } => self.sensitivities + output * self.hidden_units + unit,
            Source::Error { output } => self.errors + output,
        }
    }
}

/// One product of two factor matrices: a block of JᵀJ (two layers) or of Jᵀe (one layer).
#[derive(Debug, Clone)]
struct Product {
    /// The factor columns to form, each the sum of its terms' products, and its buffer column.
    formed: Vec<(usize, Vec<(Source, Source)>)>,
    /// Buffer columns of the product's two sides (the D factor's and the A factor's, whichever
    /// takes fewer padding columns as rows), padded with the zero column ([`gram::padded_shape`]).
    rows: Vec<usize>,
    cols: Vec<usize>,
    /// Where its sums start (row-major, `rows.len() × cols.len()`).
    at: usize,
    /// Whether it is part of JᵀJ (else of Jᵀe).
    hessian: bool,
}

/// A factor column of a product: its (row, column) index within the block (the unit pair for D,
/// the input pair for A; the second 0 for Jᵀe) and the terms whose products it sums.
type FactorTerms = Vec<((usize, usize), Vec<(Source, Source)>)>;

/// Index of an entry that is structurally zero.
const ZERO: u32 = u32::MAX;

/// How one layout's JᵀJ and Jᵀe are formed from factor products (see the module docs).
#[derive(Debug, Clone)]
pub(crate) struct FactoredPlan {
    products: Vec<Product>,
    /// For entry (p, r) of JᵀJ with r ≤ p, at p(p+1)/2 + r: the index of its sum, or [`ZERO`].
    jtj_at: Vec<u32>,
    /// For every parameter: the index of its Jᵀe sum.
    jte_at: Vec<u32>,
    sums: usize,
    columns: BlockColumns,
    /// Multiply-adds per sample: in the products as run (padding included), and in their
    /// unpadded parts.
    multiply_adds: (usize, usize),
}

/// Layer `l`'s parameter for unit `i` and input `j` (`j` = the layer's input count: the bias).
fn parameter(layout: &Layout, l: usize, i: usize, j: usize) -> usize {
    let (w_at, b_at) = layout.layer_offsets(l);
    let n_in = layout.sizes[l - 1];
    if j < n_in {
        w_at + i * n_in + j
    } else {
        b_at + i
    }
}

/// The layer, unit and input of parameter `p` (the inverse of [`parameter`]).
fn decode(layout: &Layout, p: usize) -> (usize, usize, usize) {
    let l = (1..=layout.n_layers())
        .rev()
        .find(|&l| layout.layer_offsets(l).0 <= p)
        .expect("parameter 0 is layer 1's");
    let (w_at, b_at) = layout.layer_offsets(l);
    let n_in = layout.sizes[l - 1];
    if p < b_at {
        (l, (p - w_at) / n_in, (p - w_at) % n_in)
    } else {
        (l, p - b_at, n_in)
    }
}

/// The block values a layout's factor columns are made of.
struct Values<'a> {
    layout: &'a Layout,
    last: usize,
    outputs: usize,
}

impl Values<'_> {
    /// Output o's sensitivity to unit i of layer l; None where it is zero.
    fn sensitivity(&self, l: usize, o: usize, i: usize) -> Option<Source> {
        if l == self.last {
            (i == o).then_some(Source::One)
        } else {
            Some(Source::Sensitivity {
                output: o,
                unit: self.layout.sizes[1..l].iter().sum::<usize>() + i,
            })
        }
    }

    /// Input j of layer l: an activation of the layer below, or one for the bias.
    fn input(&self, l: usize, j: usize) -> Source {
        let sizes = &self.layout.sizes;
        if j < sizes[l - 1] {
            Source::Activation {
                at: sizes[..l - 1].iter().sum::<usize>() + j,
            }
        } else {
            Source::One
        }
    }

    /// The D and A factors of JᵀJ's block between layers l ≥ m (lower triangles when l = m).
    fn hessian_factors(&self, l: usize, m: usize) -> (FactorTerms, FactorTerms) {
        let sizes = &self.layout.sizes;
        let mut d = Vec::new();
        for i in 0..sizes[l] {
            for k in 0..if l == m { i + 1 } else { sizes[m] } {
                let terms: Vec<(Source, Source)> = (0..self.outputs)
                    .filter_map(|o| Some((self.sensitivity(l, o, i)?, self.sensitivity(m, o, k)?)))
                    .collect();
                if !terms.is_empty() {
                    d.push(((i, k), terms));
                }
            }
        }
        let mut a = Vec::new();
        for j in 0..=sizes[l - 1] {
            for q in 0..if l == m { j + 1 } else { sizes[m - 1] + 1 } {
                a.push(((j, q), vec![(self.input(l, j), self.input(m, q))]));
            }
        }
        (d, a)
    }

    /// The D and A factors of layer l's part of Jᵀe.
    fn gradient_factors(&self, l: usize) -> (FactorTerms, FactorTerms) {
        let sizes = &self.layout.sizes;
        let d: FactorTerms = (0..sizes[l])
            .map(|i| {
                let terms = (0..self.outputs)
                    .filter_map(|o| Some((self.sensitivity(l, o, i)?, Source::Error { output: o })))
                    .collect();
                ((i, 0), terms)
            })
            .collect();
        let a = (0..=sizes[l - 1])
            .map(|j| ((j, 0), vec![(self.input(l, j), Source::One)]))
            .collect();
        (d, a)
    }
}

/// A product's key: its layer and, for JᵀJ, the other layer (None for Jᵀe).
type ProductKey = (usize, Option<usize>);

/// A sum's key: its product's, then the D index and the A index.
type SumKey = (ProductKey, (usize, usize), (usize, usize));

/// The products as they are added, and where each sum lies.
struct PlanBuilder {
    columns: BlockColumns,
    products: Vec<Product>,
    sums: usize,
    multiply_adds: (usize, usize),
    /// Where the sum of each (layer pair or layer's Jᵀe, D index, A index) lies.
    sum_index: std::collections::HashMap<SumKey, u32>,
}

impl PlanBuilder {
    /// The buffer column of a factor column that is one block value (times one), if it is.
    fn value_column(&self, terms: &[(Source, Source)]) -> Option<usize> {
        let [(x, y)] = terms else { return None };
        match (x, y) {
            (Source::One, v) | (v, Source::One) => Some(self.columns.of(*v)),
            _ => None,
        }
    }

    fn add_product(&mut self, key: ProductKey, d: FactorTerms, a: FactorTerms) {
        let (nd, na) = (d.len(), a.len());
        let d_keys: Vec<(usize, usize)> = d.iter().map(|(key, _)| *key).collect();
        let a_keys: Vec<(usize, usize)> = a.iter().map(|(key, _)| *key).collect();
        let (d_rows, d_cols) = gram::padded_shape(nd, na);
        let (a_rows, a_cols) = gram::padded_shape(na, nd);
        let d_is_rows = d_rows * d_cols <= a_rows * a_cols;
        // Each factor column's buffer column: the value's own, or the next formed one.
        let mut formed = Vec::new();
        let mut at_column = |terms: Vec<(Source, Source)>| {
            self.value_column(&terms).unwrap_or_else(|| {
                let column = self.columns.formed + formed.len();
                formed.push((column, terms));
                column
            })
        };
        let d_columns: Vec<usize> = d.into_iter().map(|(_, terms)| at_column(terms)).collect();
        let a_columns: Vec<usize> = a.into_iter().map(|(_, terms)| at_column(terms)).collect();
        let padded = |side: &[usize], to: usize| -> Vec<usize> {
            (0..to)
                .map(|c| side.get(c).copied().unwrap_or(ZERO_COLUMN))
                .collect()
        };
        let (rows, cols) = if d_is_rows {
            (padded(&d_columns, d_rows), padded(&a_columns, d_cols))
        } else {
            (padded(&a_columns, a_rows), padded(&d_columns, a_cols))
        };
        let width = cols.len();
        for (di, ik) in d_keys.iter().enumerate() {
            for (ai, jq) in a_keys.iter().enumerate() {
                let at = if d_is_rows {
                    di * width + ai
                } else {
                    ai * width + di
                };
                self.sum_index.insert((key, *ik, *jq), (self.sums + at) as u32);
            }
        }
        self.multiply_adds.0 += rows.len() * cols.len();
        self.multiply_adds.1 += nd * na;
        self.columns.total = self.columns.total.max(self.columns.formed + formed.len());
        let at = self.sums;
        self.sums += rows.len() * width;
        self.products.push(Product {
            formed,
            at,
            hessian: key.1.is_some(),
            rows,
            cols,
        });
    }

    /// For entry (p, r) of JᵀJ with r ≤ p, row after row: the index of its sum, or [`ZERO`].
    fn jtj_positions(&self, layout: &Layout) -> Vec<u32> {
        let n_p = layout.n_params();
        let mut jtj_at = Vec::with_capacity(n_p * (n_p + 1) / 2);
        for p in 0..n_p {
            let (l, i1, j1) = decode(layout, p);
            for r in 0..=p {
                let (m, i2, j2) = decode(layout, r);
                let (ik, jq) = if l == m {
                    ((i1.max(i2), i1.min(i2)), (j1.max(j2), j1.min(j2)))
                } else {
                    ((i1, i2), (j1, j2))
                };
                jtj_at.push(
                    self.sum_index
                        .get(&((l, Some(m)), ik, jq))
                        .copied()
                        .unwrap_or(ZERO),
                );
            }
        }
        jtj_at
    }

    /// For every parameter: the index of its Jᵀe sum.
    fn jte_positions(&self, layout: &Layout) -> Vec<u32> {
        (0..layout.n_params())
            .map(|p| {
                let (l, i, j) = decode(layout, p);
                self.sum_index[&((l, None), (i, 0), (j, 0))]
            })
            .collect()
    }
}

impl FactoredPlan {
    pub(crate) fn new(layout: &Layout) -> FactoredPlan {
        let last = layout.n_layers();
        let outputs = layout.outputs();
        let values = Values {
            layout,
            last,
            outputs,
        };
        let n_act = layout.n_activations();
        let hidden_units = layout.hidden_units();
        let mut columns = BlockColumns {
            activations: 2,
            sensitivities: 2 + n_act,
            errors: 2 + n_act + outputs * hidden_units,
            formed: 2 + n_act + outputs * hidden_units + outputs,
            total: 0,
            hidden_units,
        };
        columns.total = columns.formed;
        let mut plan = PlanBuilder {
            columns,
            products: Vec::new(),
            sums: 0,
            multiply_adds: (0, 0),
            sum_index: std::collections::HashMap::new(),
        };
        for l in 1..=last {
            for m in 1..=l {
                let (d, a) = values.hessian_factors(l, m);
                plan.add_product((l, Some(m)), d, a);
            }
            let (d, a) = values.gradient_factors(l);
            plan.add_product((l, None), d, a);
        }
        let jtj_at = plan.jtj_positions(layout);
        let jte_at = plan.jte_positions(layout);
        debug_assert!((0..layout.n_params()).all(|p| {
            let (l, i, j) = decode(layout, p);
            parameter(layout, l, i, j) == p
        }));
        FactoredPlan {
            products: plan.products,
            jtj_at,
            jte_at,
            sums: plan.sums,
            columns: plan.columns,
            multiply_adds: plan.multiply_adds,
        }
    }

    /// Length of the sums the products accumulate into.
    pub(crate) fn sums_len(&self) -> usize {
        self.sums
    }

    /// Where the values of a block go in its buffer, and how many columns it needs.
    pub(crate) fn block_columns(&self) -> BlockColumns {
        self.columns
    }

    /// Multiply-adds per sample in the products: as run (tiles padded) and unpadded.
    pub(crate) fn multiply_adds_per_sample(&self) -> (usize, usize) {
        self.multiply_adds
    }

    /// Adds one block's products to `sums`: JᵀJ's and Jᵀe's when `hessian`, else Jᵀe's only.
    /// `buffer` holds the block's [`FactoredPlan::block_columns`], `count` values each, with the
    /// zero and ones columns, the activations, sensitivities and errors in place.
    #[inline(always)]
    pub(crate) fn add_block(&self, buffer: &mut [f64], count: usize, hessian: bool, sums: &mut [f64]) {
        let buffer = &mut buffer[..self.columns.total * count];
        for product in self.products.iter().filter(|p| hessian || !p.hessian) {
            let (values, formed) = buffer.split_at_mut(self.columns.formed * count);
            let values = BlockValues {
                count,
                buffer: values,
                columns: self.columns,
            };
            for (column, terms) in &product.formed {
                let column = &mut formed[(column - self.columns.formed) * count..][..count];
                write_column(column, terms, &values);
            }
            gram::AddProduct {
                data: buffer,
                rows: &product.rows,
                cols: &product.cols,
                stride: count,
                len: count,
                product: &mut sums[product.at..product.at + product.rows.len() * product.cols.len()],
            }
            .dispatched();
        }
    }

    /// Writes JᵀJ's lower triangle (times `hessian_scale`) and Jᵀe from the products' sums.
    pub(crate) fn unpack(
        &self,
        sums: &[f64],
        hessian_scale: f64,
        jtj: &mut faer::Mat<f64>,
        jte: &mut faer::Mat<f64>,
    ) {
        let mut at = self.jtj_at.iter();
        for p in 0..jtj.nrows() {
            for r in 0..=p {
                let index = *at.next().expect("one index per lower entry");
                jtj[(p, r)] = if index == ZERO {
                    0.0
                } else {
                    hessian_scale * sums[index as usize]
                };
            }
            jte[(p, 0)] = sums[self.jte_at[p] as usize];
        }
    }
}

/// The values of one block that factor columns are made of: the buffer up to the formed
/// columns, `count` samples a column.
struct BlockValues<'a> {
    count: usize,
    buffer: &'a [f64],
    columns: BlockColumns,
}

impl BlockValues<'_> {
    /// The source's values over the block; None for [`Source::One`] (its products are copies).
    #[inline(always)]
    fn column(&self, source: Source) -> Option<&[f64]> {
        let at = (source != Source::One).then(|| self.columns.of(source))?;
        Some(&self.buffer[at * self.count..][..self.count])
    }
}

/// `column` = the sum of the terms' products, term after term (plain multiplies and adds, so the
/// same on every machine).
#[inline(always)]
fn write_column(column: &mut [f64], terms: &[(Source, Source)], values: &BlockValues<'_>) {
    // Two products (a sum over two outputs, the common case) in one pass: the same operations,
    // with one store instead of a store, a reload and a second store.
    if let [(x0, y0), (x1, y1)] = *terms {
        if let (Some(u0), Some(v0), Some(u1), Some(v1)) = (
            values.column(x0),
            values.column(y0),
            values.column(x1),
            values.column(y1),
        ) {
            for ((((c, u0), v0), u1), v1) in column.iter_mut().zip(u0).zip(v0).zip(u1).zip(v1) {
                *c = u0 * v0 + u1 * v1;
            }
            return;
        }
    }
    for (t, &(x, y)) in terms.iter().enumerate() {
        let first = t == 0;
        match (values.column(x), values.column(y)) {
            (None, None) => {
                if first {
                    column.fill(1.0);
                } else {
                    column.iter_mut().for_each(|c| *c += 1.0);
                }
            }
            (Some(v), None) | (None, Some(v)) => {
                if first {
                    column.copy_from_slice(v);
                } else {
                    column.iter_mut().zip(v).for_each(|(c, v)| *c += v);
                }
            }
            (Some(u), Some(v)) => {
                if first {
                    column.iter_mut().zip(u).zip(v).for_each(|((c, u), v)| *c = u * v);
                } else {
                    column
                        .iter_mut()
                        .zip(u)
                        .zip(v)
                        .for_each(|((c, u), v)| *c += u * v);
                }
            }
        }
    }
}
