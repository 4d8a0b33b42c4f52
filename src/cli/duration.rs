//! Durations like `30s`, `2m`, `1h30m`, `500ms`, `1.5s`.

use std::time::Duration;

/// Parse a duration; a bare number means seconds.
pub fn parse_duration(s: &str) -> Result<Duration, String> {
    let s = s.trim();
    if s.is_empty() {
        return Err("empty duration".into());
    }
    if let Ok(v) = s.parse::<f64>() {
        return secs(v, s);
    }
    let mut total = 0.0;
    let mut num = String::new();
    let mut chars = s.chars().peekable();
    while let Some(c) = chars.next() {
        if c.is_ascii_digit() || c == '.' {
            num.push(c);
            continue;
        }
        let mut unit = String::from(c);
        while let Some(&n) = chars.peek() {
            if n.is_ascii_alphabetic() {
                unit.push(n);
                chars.next();
            } else {
                break;
            }
        }
        let v: f64 = num
            .parse()
            .map_err(|_| format!("bad duration {s:?}: expected a number before {unit:?}"))?;
        num.clear();
        total += v * match unit.as_str() {
            "ms" => 1e-3,
            "s" => 1.0,
            "m" | "min" => 60.0,
            "h" => 3600.0,
            _ => {
                return Err(format!(
                    "bad duration {s:?}: unknown unit {unit:?} (use ms, s, m, h)"
                ));
            }
        };
    }
    if !num.is_empty() {
        return Err(format!("bad duration {s:?}: a unit is missing after {num}"));
    }
    secs(total, s)
}

fn secs(v: f64, s: &str) -> Result<Duration, String> {
    if v.is_finite() && v > 0.0 && v < 1e9 {
        Ok(Duration::from_secs_f64(v))
    } else {
        Err(format!("bad duration {s:?}: must be positive"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses() {
        assert_eq!(parse_duration("30s").unwrap(), Duration::from_secs(30));
        assert_eq!(parse_duration("1h30m").unwrap(), Duration::from_secs(5400));
        assert_eq!(parse_duration("500ms").unwrap(), Duration::from_millis(500));
        assert_eq!(parse_duration("2").unwrap(), Duration::from_secs(2));
        assert!(parse_duration("-3s").is_err());
        assert!(parse_duration("3x").is_err());
        assert!(parse_duration("3s4").is_err());
        assert!(parse_duration("nan").is_err());
    }
}
