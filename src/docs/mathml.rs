//! The systems' equation lines (`System::EQUATIONS`, Unicode text: `I_O θ̈ + m g l sin θ = τ`)
//! as HTML with their mathematics in MathML, which browsers typeset natively: a dotted
//! letter becomes `<mover>` (the dot a glyph of its own, so no font can lose or misplace
//! it), `x1`, `I_O`, `mT` subscripts, `²` superscripts, `½` fractions, `√(…)` roots.
//! The prose around the formulas stays text. One source for the code's documentation and
//! the page: nothing is written twice.

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

fn is_word_char(c: char) -> bool {
    c.is_alphabetic() || c.is_ascii_digit() || c == '_' || is_mark(c) || c == '′'
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
            while i < chars.len() && is_word_char(chars[i]) {
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

/// An identifier: a base letter (with its marks and primes) and a subscript of the rest.
pub(super) fn identifier(word: &str) -> String {
    if FUNCTIONS.contains(&word) {
        return format!("<mi mathvariant=\"normal\">{}</mi>", escape(word));
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
                let sup = match c {
                    '²' => Some("<mn>2</mn>"),
                    '³' => Some("<mn>3</mn>"),
                    'ᵀ' => Some("<mi mathvariant=\"normal\">T</mi>"),
                    '⁻' => None,
                    _ => None,
                };
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
                    items.push(format!("<msup>{base}{s}</msup>"));
                } else if *c == '⁻' && toks.get(i + 1) == Some(&Tok::Sym('¹')) {
                    let base = items.pop().unwrap_or_else(|| "<mrow/>".into());
                    items.push(format!(
                        "<msup>{base}<mrow><mo>−</mo><mn>1</mn></mrow></msup>"
                    ));
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
    // Math tokens: words that are symbols, numbers, symbols other than sentence punctuation;
    // spaces join a run.
    let is_math = |t: &Tok| match t {
        Tok::Word(w) => !is_prose(w),
        Tok::Number(_) => true,
        Tok::Space => false,
        Tok::Sym(c) => !matches!(c, ',' | ';' | ':' | '.' | '!' | '?' | '"' | '\''),
    };
    let mut out = String::new();
    let mut i = 0;
    while i < n {
        if !is_math(&toks[i]) {
            out.push_str(&text(&toks[i..i + 1]));
            i += 1;
            continue;
        }
        // A run: math tokens and the spaces and commas between them, up to prose.
        let mut j = i;
        let mut end = i;
        while j < n {
            match &toks[j] {
                t if is_math(t) => end = j + 1,
                Tok::Space => {}
                // A comma inside brackets belongs to the formula: (x, y).
                Tok::Sym(',') if depth_at(&toks[i..j]) > 0 => {}
                _ => break,
            }
            j += 1;
        }
        let (mut a, mut b) = (i, end);
        // Leave unmatched brackets at either end to the prose.
        loop {
            let run = &toks[a..b];
            if run.first().is_some_and(is_open) && depth_at(run) > 0 {
                out.push_str(&text(&toks[a..a + 1]));
                a += 1;
            } else if b > a
                && ((is_close(&toks[b - 1]) && min_depth(&toks[a..b]) < 0) || is_open(&toks[b - 1]))
            {
                b -= 1;
            } else {
                break;
            }
        }
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
        // What the trimming left out at the end goes on as text.
        out.push_str(&text(&toks[b.max(a)..end]));
        i = end.max(i + 1);
    }
    out
}

/// Bracket depth at the end of `toks`.
fn depth_at(toks: &[Tok]) -> i32 {
    toks.iter()
        .map(|t| i32::from(is_open(t)) - i32::from(is_close(t)))
        .sum()
}

/// The lowest bracket depth reached in `toks`.
fn min_depth(toks: &[Tok]) -> i32 {
    let mut d = 0;
    let mut m = 0;
    for t in toks {
        d += i32::from(is_open(t)) - i32::from(is_close(t));
        m = m.min(d);
    }
    m
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
}
