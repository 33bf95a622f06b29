//! Number formatting for labels (short) and data files (exact).

/// A short label for `v` with about three significant digits: `0`, `0.5`, `12.3`, `1.23e-4`,
/// `-2e6`. Non-finite values give `NaN`, `inf`, `-inf`.
pub fn short(v: f64) -> String {
    if !v.is_finite() {
        return non_finite(v);
    }
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (1e-3..1e4).contains(&a) {
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        trim_decimal(format!("{v:.decimals$}"))
    } else {
        trim_sci(sci(v, 2))
    }
}

/// A tick label for `v` on an axis whose ticks are `step` apart: enough digits to tell
/// neighbouring ticks apart, no float noise (`0.30000000000000004` prints as `0.3`).
pub fn tick(v: f64, step: f64) -> String {
    if !v.is_finite() {
        return non_finite(v);
    }
    if !(step.is_finite() && step > 0.0) {
        return short(v);
    }
    if v.abs() < step * 1e-9 {
        return "0".into();
    }
    let step_exp = step.log10().floor() as i32;
    let a = v.abs();
    if step >= 1e-3 && a < 1e5 {
        let decimals = (-step_exp).max(0) as usize;
        trim_decimal(format!("{v:.decimals$}"))
    } else {
        let digits = (a.log10().floor() as i32 - step_exp).clamp(0, 8) as usize;
        trim_sci(sci(v, digits))
    }
}

/// `v` written so that it parses back to the same `f64` (shortest round-trip form), using
/// exponent notation for very small or large magnitudes: `0.1`, `12`, `1e-300`.
/// Non-finite values give `NaN`, `inf`, `-inf`.
pub fn exact(v: f64) -> String {
    if !v.is_finite() {
        return non_finite(v);
    }
    let a = v.abs();
    if v == 0.0 || (1e-5..1e16).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// Finite `v` in exponent notation with `digits` decimals: rounded to nearest, or cut toward
/// zero where rounding would pass `f64::MAX` (`1.8e308` for `f64::MAX` would read back as
/// infinity; `1.79e308` does not).
fn sci(v: f64, digits: usize) -> String {
    let rounded = format!("{v:.digits$e}");
    if rounded.parse::<f64>().is_ok_and(f64::is_finite) {
        return rounded;
    }
    // 17 significant digits name `v` exactly; cutting decimals off moves toward zero.
    let exact = format!("{v:.16e}");
    let (mantissa, exponent) = exact.split_once('e').unwrap_or((&exact, "0"));
    let keep = mantissa
        .find('.')
        .map_or(mantissa.len(), |dot| (dot + 1 + digits).min(mantissa.len()));
    format!("{}e{exponent}", &mantissa[..keep])
}

fn non_finite(v: f64) -> String {
    if v.is_nan() {
        "NaN".into()
    } else if v > 0.0 {
        "inf".into()
    } else {
        "-inf".into()
    }
}

fn trim_decimal(s: String) -> String {
    if s.contains('.') {
        let t = s.trim_end_matches('0').trim_end_matches('.');
        if t == "-0" { "0".into() } else { t.into() }
    } else if s == "-0" {
        "0".into()
    } else {
        s
    }
}

fn trim_sci(s: String) -> String {
    match s.split_once('e') {
        Some((m, e)) => format!("{}e{e}", trim_decimal(m.to_string())),
        None => s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn short_labels() {
        assert_eq!(short(0.0), "0");
        assert_eq!(short(0.5), "0.5");
        assert_eq!(short(12.34), "12.3");
        assert_eq!(short(1.234e-4), "1.23e-4");
        assert_eq!(short(-2e6), "-2e6");
        assert_eq!(short(f64::NAN), "NaN");
        assert_eq!(tick(0.30000000000000004, 0.1), "0.3");
        assert_eq!(tick(2e-5, 1e-5), "2e-5");
        assert_eq!(tick(1.5e6, 5e5), "1.5e6");
        assert_eq!(tick(-1e-17, 0.2), "0");
        assert_eq!(exact(0.1), "0.1");
        assert_eq!(exact(1e-300), "1e-300");
        assert_eq!(exact(1e-300).parse::<f64>().unwrap(), 1e-300);
        // Rounding up would pass f64::MAX ("1.8e308" reads back as infinity).
        assert_eq!(short(f64::MAX), "1.79e308");
        assert_eq!(short(f64::MIN), "-1.79e308");
        assert_eq!(tick(f64::MAX, 1e307), "1.7e308");
        assert_eq!(tick(f64::MAX, 1e308), "1e308");
    }
}
