//! Export formats of a [`Linearization`]: JSON (canonical), Python in OpenModelica's
//! `linearized_model.py` convention, and CSV.

use super::Linearization;
use nalgebra::DMatrix;

/// Round-trip float text (Rust's shortest representation that parses back exactly).
fn num(v: f64) -> String {
    assert!(v.is_finite(), "non-finite value in a linearisation");
    format!("{v:?}")
}

fn list(v: &[f64]) -> String {
    format!(
        "[{}]",
        v.iter().map(|&x| num(x)).collect::<Vec<_>>().join(", ")
    )
}

fn quoted(names: &[String], q: char) -> String {
    names
        .iter()
        .map(|n| {
            format!(
                "{q}{}{q}",
                n.replace('\\', "\\\\").replace(q, &format!("\\{q}"))
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Row-major nested lists; an empty matrix stays `[]` (its shape is in n, m, p).
fn rows(m: &DMatrix<f64>) -> String {
    let rows: Vec<String> = (0..m.nrows())
        .map(|i| list(&m.row(i).iter().copied().collect::<Vec<_>>()))
        .collect();
    format!("[{}]", rows.join(", "))
}

/// The canonical format: dimensions, names in FMI order, operating point, residual,
/// A, B, C, D row-major, and the method.
pub fn to_json(l: &Linearization) -> String {
    let params: Vec<String> = l
        .parameter_names
        .iter()
        .zip(&l.point.p)
        .map(|(n, v)| format!("\"{n}\": {}", num(*v)))
        .collect();
    // Only a reduced model says what it left out (the full one's text is unchanged).
    let reduction = if l.eliminated.is_empty() && l.dropped.is_empty() {
        String::new()
    } else {
        format!(
            "\n  \"eliminated\": [{}],\n  \"dropped\": [{}],",
            quoted(&l.eliminated, '"'),
            quoted(&l.dropped, '"')
        )
    };
    format!(
        "{{\n  \"model\": \"{}\",\n  \"n\": {},\n  \"m\": {},\n  \"p\": {},\n  \"states\": [{}],{}\n  \"inputs\": [{}],\n  \"outputs\": [{}],\n  \"t0\": {},\n  \"x0\": {},\n  \"u0\": {},\n  \"y0\": {},\n  \"parameters\": {{{}}},\n  \"residual\": {},\n  \"A\": {},\n  \"B\": {},\n  \"C\": {},\n  \"D\": {},\n  \"method\": \"{}\"\n}}\n",
        l.model,
        l.a.nrows(),
        l.b.ncols(),
        l.c.nrows(),
        quoted(&l.state_names, '"'),
        reduction,
        quoted(&l.input_names, '"'),
        quoted(&l.output_names, '"'),
        num(l.point.t),
        list(&l.x0()),
        list(&l.point.u),
        list(&l.y0),
        params.join(", "),
        num(l.residual),
        rows(&l.a),
        rows(&l.b),
        rows(&l.c),
        rows(&l.d),
        l.method
    )
}

/// OpenModelica's `linearized_model.py` convention: `linearized_model()` returns
/// `(n, m, p, x0, u0, A, B, C, D, stateVars, inputVars, outputVars)`.
pub fn to_py(l: &Linearization) -> String {
    format!(
        "# Linearisation of {model} by mbfmu ({method}); residual ‖f(x0,u0)‖∞ = {res}\n\
         def linearized_model():\n    # {model}\n    # der(x) = A * x + B * u\n    # y = C * x + D * u\n\
         \x20   n = {n} # number of states\n    m = {m} # number of inputs\n    p = {p} # number of outputs\n\n\
         \x20   x0 = {x0}\n    u0 = {u0}\n\n\
         \x20   A = {a}\n\n    B = {b}\n\n    C = {c}\n\n    D = {d}\n\n\
         \x20   stateVars  = [{sv}]\n    inputVars  = [{iv}]\n    outputVars = [{ov}]\n\n\
         \x20   return (n, m, p, x0, u0, A, B, C, D, stateVars, inputVars, outputVars)\n",
        model = l.model,
        method = l.method,
        res = num(l.residual),
        n = l.a.nrows(),
        m = l.b.ncols(),
        p = l.c.nrows(),
        x0 = list(&l.x0()),
        u0 = list(&l.point.u),
        a = rows(&l.a),
        b = rows(&l.b),
        c = rows(&l.c),
        d = rows(&l.d),
        sv = quoted(&l.state_names, '\''),
        iv = quoted(&l.input_names, '\''),
        ov = quoted(&l.output_names, '\''),
    )
}

/// One line per matrix entry: `matrix,row_name,column_name,value`.
pub fn to_csv(l: &Linearization) -> String {
    let mut out = String::from("matrix,row,column,value\n");
    let blocks = [
        ("A", &l.a, &l.state_names, &l.state_names),
        ("B", &l.b, &l.state_names, &l.input_names),
        ("C", &l.c, &l.output_names, &l.state_names),
        ("D", &l.d, &l.output_names, &l.input_names),
    ];
    for (name, m, rows, cols) in blocks {
        for i in 0..m.nrows() {
            for j in 0..m.ncols() {
                out.push_str(&format!(
                    "{name},{},{},{}\n",
                    rows[i],
                    cols[j],
                    num(m[(i, j)])
                ));
            }
        }
    }
    out
}
