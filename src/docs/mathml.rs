//! The systems' equation lines (`System::EQUATIONS`, Unicode text: `I_O θ̈ + m g l sin θ = τ`)
//! as HTML with their mathematics in MathML, which browsers typeset natively: a dotted
//! letter becomes `<mover>` (the dot a glyph of its own, so no font can lose or misplace
//! it), `x1`, `I_O`, `mT` subscripts, `²` and `ᵀ` superscripts (on a subscripted name both
//! in one `<msubsup>`: `a_z²`), `½` fractions, `√(…)` roots; a name with a lower-case run of
//! three letters (`WhippleBicycle`) stays one token. The prose around the formulas stays
//! text, with its hyphens (`λ-method`) and apostrophes (`benchmark's`). One source for the
//! code's documentation and the page: nothing is written twice.

/// Function names set upright.
const FUNCTIONS: &[&str] = &[
    "sin", "cos", "tan", "atan2", "arccos", "arcsin", "exp", "ln", "log", "diag", "sign", "max",
    "min",
];
/// Two-letter English words that are never symbols.
const SHORT_WORDS: &[&str] = &[
    "of", "at", "by", "on", "in", "to", "is", "it", "as", "or", "an", "be", "if", "no", "so", "up",
    "we", "do", "iff", "and", "the", "e.g",
];

fn escape(s: &str) -> String {
    quick_xml::escape::escape(s).into_owned()
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    /// A run of letters, digits, `_`, combining marks and primes.
    Word(String),
    Number(String),
    Space,
    /// Any other character.
    Sym(char),
}

fn is_mark(c: char) -> bool {
    ('\u{0300}'..='\u{036f}').contains(&c)
}

/// A superscript character as the MathML of its exponent (`ᵀ` is a letter to Unicode, but
/// a superscript here, never part of a name).
fn superscript_char(c: char) -> Option<&'static str> {
    Some(match c {
        '²' => "<mn>2</mn>",
        '³' => "<mn>3</mn>",
        'ᵀ' => "<mi mathvariant=\"normal\">T</mi>",
        _ => return None,
    })
}

fn is_word_char(c: char) -> bool {
    (c.is_alphabetic() || c.is_ascii_digit() || c == '_' || is_mark(c) || c == '′')
        && superscript_char(c).is_none()
}

/// `base` with the exponent `sup` (MathML): a subscripted base takes it beside its
/// subscript (`<msubsup>`), so `a_z²` reads as the square of a_z, not a_z's subscript
/// squared or a bracket's square after it.
pub(super) fn superscript(base: &str, sup: &str) -> String {
    match base
        .strip_prefix("<msub>")
        .and_then(|b| b.strip_suffix("</msub>"))
    {
        // identifier() makes `<msub>` of exactly base and subscript.
        Some(inner) if !inner.contains("<msub>") => format!("<msubsup>{inner}{sup}</msubsup>"),
        _ => format!("<msup>{base}{sup}</msup>"),
    }
}

/// A precomposed Latin letter with a dot or two above (ẋ, ẍ, ṙ, ż) as its letter and the
/// combining mark, so it is typeset as the decomposed ones are.
fn decompose(c: char) -> Option<(char, char)> {
    match c {
        'Ä' => Some(('A', '\u{0308}')),
        'Ë' => Some(('E', '\u{0308}')),
        'Ï' => Some(('I', '\u{0308}')),
        'Ö' => Some(('O', '\u{0308}')),
        'Ü' => Some(('U', '\u{0308}')),
        'ä' => Some(('a', '\u{0308}')),
        'ë' => Some(('e', '\u{0308}')),
        'ï' => Some(('i', '\u{0308}')),
        'ö' => Some(('o', '\u{0308}')),
        'ü' => Some(('u', '\u{0308}')),
        'ÿ' => Some(('y', '\u{0308}')),
        'Ċ' => Some(('C', '\u{0307}')),
        'ċ' => Some(('c', '\u{0307}')),
        'Ė' => Some(('E', '\u{0307}')),
        'ė' => Some(('e', '\u{0307}')),
        'Ġ' => Some(('G', '\u{0307}')),
        'ġ' => Some(('g', '\u{0307}')),
        'İ' => Some(('I', '\u{0307}')),
        'Ÿ' => Some(('Y', '\u{0308}')),
        'Ż' => Some(('Z', '\u{0307}')),
        'ż' => Some(('z', '\u{0307}')),
        'Ȧ' => Some(('A', '\u{0307}')),
        'ȧ' => Some(('a', '\u{0307}')),
        'Ȯ' => Some(('O', '\u{0307}')),
        'ȯ' => Some(('o', '\u{0307}')),
        'Ḃ' => Some(('B', '\u{0307}')),
        'ḃ' => Some(('b', '\u{0307}')),
        'Ḋ' => Some(('D', '\u{0307}')),
        'ḋ' => Some(('d', '\u{0307}')),
        'Ḟ' => Some(('F', '\u{0307}')),
        'ḟ' => Some(('f', '\u{0307}')),
        'Ḣ' => Some(('H', '\u{0307}')),
        'ḣ' => Some(('h', '\u{0307}')),
        'Ḧ' => Some(('H', '\u{0308}')),
        'ḧ' => Some(('h', '\u{0308}')),
        'Ṁ' => Some(('M', '\u{0307}')),
        'ṁ' => Some(('m', '\u{0307}')),
        'Ṅ' => Some(('N', '\u{0307}')),
        'ṅ' => Some(('n', '\u{0307}')),
        'Ṗ' => Some(('P', '\u{0307}')),
        'ṗ' => Some(('p', '\u{0307}')),
        'Ṙ' => Some(('R', '\u{0307}')),
        'ṙ' => Some(('r', '\u{0307}')),
        'Ṡ' => Some(('S', '\u{0307}')),
        'ṡ' => Some(('s', '\u{0307}')),
        'Ṫ' => Some(('T', '\u{0307}')),
        'ṫ' => Some(('t', '\u{0307}')),
        'Ẅ' => Some(('W', '\u{0308}')),
        'ẅ' => Some(('w', '\u{0308}')),
        'Ẇ' => Some(('W', '\u{0307}')),
        'ẇ' => Some(('w', '\u{0307}')),
        'Ẋ' => Some(('X', '\u{0307}')),
        'ẋ' => Some(('x', '\u{0307}')),
        'Ẍ' => Some(('X', '\u{0308}')),
        'ẍ' => Some(('x', '\u{0308}')),
        'Ẏ' => Some(('Y', '\u{0307}')),
        'ẏ' => Some(('y', '\u{0307}')),
        'ẗ' => Some(('t', '\u{0308}')),
        _ => None,
    }
}

fn tokens(line: &str) -> Vec<Tok> {
    let chars: Vec<char> = line
        .chars()
        .flat_map(|c| match decompose(c) {
            Some((b, m)) => vec![b, m],
            None => vec![c],
        })
        .collect();
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c.is_whitespace() {
            while i < chars.len() && chars[i].is_whitespace() {
                i += 1;
            }
            out.push(Tok::Space);
        } else if c.is_ascii_digit() {
            let start = i;
            while i < chars.len()
                && (chars[i].is_ascii_digit()
                    || (chars[i] == '.' && chars.get(i + 1).is_some_and(|d| d.is_ascii_digit())))
            {
                i += 1;
            }
            out.push(Tok::Number(chars[start..i].iter().collect()));
        } else if is_word_char(c) {
            let start = i;
            // An apostrophe between letters is inside the word: benchmark's.
            while i < chars.len()
                && (is_word_char(chars[i])
                    || (chars[i] == '\''
                        && chars[i - 1].is_alphabetic()
                        && chars.get(i + 1).is_some_and(|d| d.is_alphabetic())))
            {
                i += 1;
            }
            out.push(Tok::Word(chars[start..i].iter().collect()));
        } else {
            out.push(Tok::Sym(c));
            i += 1;
        }
    }
    out
}

/// Whether a word is prose (an English word) rather than a symbol.
fn is_prose(word: &str) -> bool {
    if FUNCTIONS.contains(&word) {
        return false;
    }
    if SHORT_WORDS.contains(&word.to_lowercase().as_str()) {
        return true;
    }
    if !word.is_ascii() || word.chars().count() <= 2 {
        return false;
    }
    // camelCase code words (doStep, fmi2Discard) are names in prose, not symbols.
    if word.len() >= 4
        && word.starts_with(|c: char| c.is_ascii_lowercase())
        && word.chars().any(|c| c.is_ascii_uppercase())
    {
        return true;
    }
    // ITxx, T_phi, atan2, l0: symbols; Equation, torque: prose.
    let inner_upper = word.chars().skip(1).any(|c| c.is_ascii_uppercase());
    let digit_or_sub = word.chars().any(|c| c.is_ascii_digit() || c == '_');
    !(inner_upper || digit_or_sub)
}

fn is_open(t: &Tok) -> bool {
    matches!(t, Tok::Sym('(' | '[' | '{'))
}

fn is_close(t: &Tok) -> bool {
    matches!(t, Tok::Sym(')' | ']' | '}'))
}

/// Characters that make a math run worth typesetting on their own.
fn is_mathy(t: &Tok) -> bool {
    match t {
        Tok::Word(w) => !w.is_ascii() || w.contains('_') || w.chars().count() >= 2,
        Tok::Number(_) => true,
        Tok::Sym(c) => !c.is_ascii() || matches!(c, '=' | '+' | '/' | '<' | '>' | '^' | '*'),
        Tok::Space => false,
    }
}

/// Whether a word is a name of its own rather than a letter with a subscript: it holds a
/// run of three lower-case letters (WhippleBicycle, Table; not IBxx, vx0, ωn, θ̇R).
fn is_name(word: &str) -> bool {
    let mut run = 0;
    for c in word.chars() {
        run = if c.is_lowercase() { run + 1 } else { 0 };
        if run >= 3 {
            return true;
        }
    }
    false
}

/// An identifier: a base letter (with its marks and primes) and a subscript of the rest
/// (`I_O`: what follows the underscore), or a name as one token.
pub(super) fn identifier(word: &str) -> String {
    if FUNCTIONS.contains(&word) {
        return format!("<mi mathvariant=\"normal\">{}</mi>", escape(word));
    }
    if !word.contains('_') && is_name(word) {
        return format!("<mi>{}</mi>", escape(word));
    }
    let (base, sub) = match word.split_once('_') {
        Some((b, s)) => (b.to_string(), s.to_string()),
        None => {
            let mut chars = word.chars().peekable();
            let mut base = String::new();
            if let Some(first) = chars.next() {
                base.push(first);
            }
            while let Some(&c) = chars.peek() {
                if is_mark(c) || c == '′' {
                    base.push(c);
                    chars.next();
                } else {
                    break;
                }
            }
            (base, chars.collect())
        }
    };
    // Marks: a dot (U+0307) or two (U+0308) over the letter, as their own glyphs.
    let letter: String = base.chars().filter(|c| !is_mark(*c) && *c != '′').collect();
    let primes: String = base.chars().filter(|c| *c == '′').collect();
    let mut el = format!("<mi>{}</mi>", escape(&letter));
    for m in base.chars().filter(|c| is_mark(*c)) {
        let accent = match m {
            '\u{0307}' => "˙",
            '\u{0308}' => "¨",
            '\u{0302}' => "^",
            '\u{0304}' => "¯",
            _ => "˙",
        };
        // Not `accent="true"`: Chromium then sets the dot onto the letter's top stroke with
        // DejaVu Math TeX Gyre (Debian's fallback math font), where it cannot be seen; as an
        // over-script it stands above the letter in every font (the page test looks).
        el = format!("<mover>{el}<mo>{accent}</mo></mover>");
    }
    if !primes.is_empty() {
        el = format!("<msup>{el}<mo>{primes}</mo></msup>");
    }
    if !sub.is_empty() {
        let sub_el = if sub.chars().all(|c| c.is_ascii_digit()) {
            format!("<mn>{sub}</mn>")
        } else {
            // A subscript may hold marks of its own (rare): keep it as one name.
            format!("<mi>{}</mi>", escape(&sub))
        };
        el = format!("<msub>{el}{sub_el}</msub>");
    }
    el
}

/// MathML elements (no `<math>`) of a token run.
fn elements(toks: &[Tok]) -> String {
    let mut items: Vec<String> = Vec::new();
    let mut i = 0;
    while i < toks.len() {
        match &toks[i] {
            Tok::Space => {}
            Tok::Word(w) => items.push(identifier(w)),
            Tok::Number(n) => items.push(format!("<mn>{n}</mn>")),
            Tok::Sym(c) => {
                let sup = superscript_char(*c);
                let frac = match c {
                    '½' => Some(("1", "2")),
                    '⅓' => Some(("1", "3")),
                    '⅔' => Some(("2", "3")),
                    '¼' => Some(("1", "4")),
                    '¾' => Some(("3", "4")),
                    _ => None,
                };
                if let Some(s) = sup {
                    let base = items.pop().unwrap_or_else(|| "<mrow/>".into());
                    items.push(superscript(&base, s));
                } else if *c == '⁻' && toks.get(i + 1) == Some(&Tok::Sym('¹')) {
                    let base = items.pop().unwrap_or_else(|| "<mrow/>".into());
                    items.push(superscript(&base, "<mrow><mo>−</mo><mn>1</mn></mrow>"));
                    i += 1;
                } else if let Some((n, d)) = frac {
                    items.push(format!("<mfrac><mn>{n}</mn><mn>{d}</mn></mfrac>"));
                } else if *c == '√' {
                    // √(…): the group under the root; √x: the next item.
                    let mut j = i + 1;
                    while toks.get(j) == Some(&Tok::Space) {
                        j += 1;
                    }
                    if toks.get(j).is_some_and(is_open) {
                        let mut depth = 0;
                        let mut k = j;
                        while k < toks.len() {
                            if is_open(&toks[k]) {
                                depth += 1;
                            } else if is_close(&toks[k]) {
                                depth -= 1;
                                if depth == 0 {
                                    break;
                                }
                            }
                            k += 1;
                        }
                        let inner = &toks[j + 1..k.min(toks.len())];
                        items.push(format!("<msqrt>{}</msqrt>", elements(inner)));
                        i = k.min(toks.len());
                    } else if j < toks.len() {
                        items.push(format!("<msqrt>{}</msqrt>", elements(&toks[j..j + 1])));
                        i = j;
                    } else {
                        items.push("<mo>√</mo>".into());
                    }
                } else {
                    let op = match c {
                        '-' => '−',
                        '*' => '·',
                        other => *other,
                    };
                    items.push(format!("<mo>{}</mo>", escape(&op.to_string())));
                }
            }
        }
        i += 1;
    }
    items.concat()
}

/// `<math>` of a token run.
fn math(toks: &[Tok]) -> String {
    format!("<math><mrow>{}</mrow></math>", elements(toks))
}

fn text(toks: &[Tok]) -> String {
    let s: String = toks
        .iter()
        .map(|t| match t {
            Tok::Word(w) | Tok::Number(w) => w.clone(),
            Tok::Space => " ".into(),
            Tok::Sym(c) => c.to_string(),
        })
        .collect();
    escape(&s)
}

/// One equation line as HTML: its formulas in `<math>`, its prose as text.
pub fn line_html(line: &str) -> String {
    let toks = tokens(line);
    let n = toks.len();
    // Math tokens: words that are symbols, numbers, symbols other than sentence punctuation
    // and a hyphen joining a word of prose (λ-method); spaces join a run.
    let is_math = |k: usize| match &toks[k] {
        Tok::Word(w) => !is_prose(w),
        Tok::Number(_) => true,
        Tok::Space => false,
        Tok::Sym('-') => {
            !(k > 0
                && toks[k - 1] != Tok::Space
                && matches!(toks.get(k + 1), Some(Tok::Word(w)) if is_prose(w)))
        }
        Tok::Sym(c) => !matches!(c, ',' | ';' | ':' | '.' | '!' | '?' | '"' | '\''),
    };
    let mut out = String::new();
    let mut i = 0;
    while i < n {
        if !is_math(i) {
            out.push_str(&text(&toks[i..i + 1]));
            i += 1;
            continue;
        }
        // A run: math tokens and the spaces and commas between them, up to prose.
        let mut j = i;
        let mut end = i;
        while j < n {
            match &toks[j] {
                _ if is_math(j) => end = j + 1,
                Tok::Space => {}
                // A comma inside brackets belongs to the formula: (x, y).
                Tok::Sym(',') if depth_at(&toks[i..j]) > 0 => {}
                _ => break,
            }
            j += 1;
        }
        // An unmatched bracket goes to the prose and the formula ends before it (`= 0 (a:
        // front axle)`); what follows it is looked at again.
        if let Some(cut) = unmatched(&toks[i..end]) {
            if cut == 0 {
                out.push_str(&text(&toks[i..i + 1]));
                i += 1;
                continue;
            }
            end = i + cut;
        }
        let (a, mut b) = (i, end);
        while b > a && toks[b - 1] == Tok::Space {
            b -= 1;
        }
        let run = &toks[a..b];
        let worth =
            run.iter().filter(|t| **t != Tok::Space).count() >= 2 || run.iter().any(is_mathy);
        if worth {
            out.push_str(&math(run));
        } else {
            out.push_str(&text(run));
        }
        // The spaces trimmed at the end go on as text.
        out.push_str(&text(&toks[b..end]));
        i = end;
    }
    out
}

/// The position of the first unmatched bracket in `toks`: a close without its open, or an
/// open not closed within `toks`.
fn unmatched(toks: &[Tok]) -> Option<usize> {
    let mut open = Vec::new();
    for (k, t) in toks.iter().enumerate() {
        if is_open(t) {
            open.push(k);
        } else if is_close(t) && open.pop().is_none() {
            return Some(k);
        }
    }
    open.first().copied()
}

/// Bracket depth at the end of `toks`.
fn depth_at(toks: &[Tok]) -> i32 {
    toks.iter()
        .map(|t| i32::from(is_open(t)) - i32::from(is_close(t)))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dots_are_glyphs_of_their_own_over_the_letter() {
        let h = line_html("T = ½ I_O θ̇², V = −m g l cos θ");
        assert!(h.contains("<mover><mi>θ</mi><mo>˙</mo></mover>"), "{h}");
        assert!(h.contains("<mfrac><mn>1</mn><mn>2</mn></mfrac>"), "{h}");
        assert!(h.contains("<msub><mi>I</mi><mi>O</mi></msub>"), "{h}");
        assert!(h.contains("<mi mathvariant=\"normal\">cos</mi>"), "{h}");
        let h = line_html("I1 Ω̇1 − (I2 − I3) Ω2 Ω3 = N1");
        assert!(
            h.contains("<msub><mover><mi>Ω</mi><mo>˙</mo></mover><mn>1</mn></msub>"),
            "{h}"
        );
        assert!(line_html("θ̈").contains("<mo>¨</mo>"));
        let h = line_html("m ẍ + c ẋ + k x = F");
        assert!(h.contains("<mover><mi>x</mi><mo>¨</mo></mover>"), "{h}");
    }

    #[test]
    fn prose_stays_text_and_every_character_is_kept() {
        let line =
            "Equation of motion, formed by automatic differentiation of L: I_O θ̈ + m g l sin θ = τ";
        let h = line_html(line);
        assert!(
            h.starts_with("Equation of motion, formed by automatic differentiation of L: <math>")
        );
        assert_eq!(h.matches("<math>").count(), 1, "{h}");
        let h = line_html("Generalised forces: T_phi on the roll, T_delta on the steer");
        assert!(h.contains("on the roll"), "{h}");
        assert!(line_html("after every doStep q is").contains("every doStep "));
        let h = line_html("generalised force τ (torque at O)");
        assert!(h.ends_with("(torque at O)"), "{h}");
        let h = line_html("period 4 √(I_O/(m g l)) K(sin(θ0/2))");
        assert!(h.contains("<msqrt>"), "{h}");
    }

    #[test]
    fn a_name_in_a_formula_stays_one_token() {
        let h = line_html("M q̈ + v C1 q̇ + (g K0 + v² K2) q = f (WhippleBicycle): self-stable");
        assert!(h.contains("<mi>WhippleBicycle</mi>"), "{h}");
        assert!(!h.contains("hippleBicycle</mi></msub>"), "{h}");
        // Genuine subscripts stay subscripts: digits, capitals, short lower-case tails.
        assert!(h.contains("<msub><mi>C</mi><mn>1</mn></msub>"), "{h}");
        assert_eq!(identifier("r_1"), "<msub><mi>r</mi><mn>1</mn></msub>");
        assert_eq!(identifier("rR"), "<msub><mi>r</mi><mi>R</mi></msub>");
        assert_eq!(identifier("IBxx"), "<msub><mi>I</mi><mi>Bxx</mi></msub>");
        assert_eq!(identifier("vx0"), "<msub><mi>v</mi><mi>x0</mi></msub>");
        assert_eq!(identifier("ωn"), "<msub><mi>ω</mi><mi>n</mi></msub>");
        assert_eq!(
            identifier("theta_dot"),
            "<msub><mi>theta</mi><mi>dot</mi></msub>"
        );
        assert_eq!(identifier("Table1"), "<mi>Table1</mi>");
    }

    #[test]
    fn a_superscript_binds_to_the_subscripted_name_before_it() {
        // Inside a root: the square is a_z's, beside its subscript, and inside the root.
        let h = line_html("z(C_F) + rF √(1 − a_z²) = 0");
        assert!(
            h.contains("<msqrt><mn>1</mn><mo>−</mo><msubsup><mi>a</mi><mi>z</mi><mn>2</mn></msubsup></msqrt>"),
            "{h}"
        );
        let h = line_html("E = ½ m x_dot²");
        assert!(
            h.contains("<msubsup><mi>x</mi><mi>dot</mi><mn>2</mn></msubsup>"),
            "{h}"
        );
        let h = line_html("ẋ1² + θ̇R²");
        assert!(
            h.contains(
                "<msubsup><mover><mi>x</mi><mo>˙</mo></mover><mn>1</mn><mn>2</mn></msubsup>"
            ),
            "{h}"
        );
        assert!(
            h.contains(
                "<msubsup><mover><mi>θ</mi><mo>˙</mo></mover><mi>R</mi><mn>2</mn></msubsup>"
            ),
            "{h}"
        );
        // No subscript: a plain power; a root of a sum.
        let h = line_html("r = √(a² + b²)");
        assert!(
            h.contains("<msqrt><msup><mi>a</mi><mn>2</mn></msup><mo>+</mo><msup><mi>b</mi><mn>2</mn></msup></msqrt>"),
            "{h}"
        );
        // ᵀ is a superscript, not a subscript letter of the name.
        let h = line_html("M q̈ + Gᵀ λ = Q");
        assert!(
            h.contains("<msup><mi>G</mi><mi mathvariant=\"normal\">T</mi></msup>"),
            "{h}"
        );
        let h = line_html("R_B⁻¹");
        assert!(
            h.contains("<msubsup><mi>R</mi><mi>B</mi><mrow><mo>−</mo>"),
            "{h}"
        );
    }

    #[test]
    fn prose_keeps_its_hyphens_apostrophes_and_unmatched_brackets() {
        let h = line_html("constraints differentiated to acceleration level (λ-method); the state");
        assert!(
            h.contains("(<math><mrow><mi>λ</mi></mrow></math>-method);"),
            "{h}"
        );
        let h = line_html("it reproduces the benchmark's M q̈ = f");
        assert!(
            h.contains("the benchmark&apos;s <math><mrow><mi>M</mi>"),
            "{h}"
        );
        // A minus between symbols stays a minus.
        assert!(line_html("a-b").contains("<mo>−</mo>"));
        let h = line_html("z(C_F) + rF √(1 − a_z²) = 0 (a: front axle); it fixes θ");
        assert!(
            h.contains("<mn>0</mn></mrow></math> (a: front axle); it fixes "),
            "{h}"
        );
        assert_eq!(h.matches("<math>").count(), 2, "{h}");
        let h = line_html("T = Σ ½ m |v|² + ½ ωᵀ I ω over the four bodies");
        assert!(
            h.contains("<msup><mi>ω</mi><mi mathvariant=\"normal\">T</mi></msup>"),
            "{h}"
        );
    }
}
