//! Command-line options for the examples: `--name value` pairs and bare `--flag`s, with
//! errors (not panics) that name the option and the value that did not parse.
//!
//! ```
//! // With no `--steps` on the command line the default comes back.
//! let steps: u32 = simkit::cli::arg("--steps", 100).unwrap();
//! assert_eq!(steps, 100);
//! assert!(!simkit::cli::flag("--gpu"));
//! ```

use crate::backend::{Error, Result};

/// The value after `name` on the command line parsed as `T`, or `default` when `name` is
/// absent. A missing or unparsable value is an [`Error::InvalidParameter`] naming both.
pub fn arg<T: std::str::FromStr>(name: &str, default: T) -> Result<T> {
    arg_in(&std::env::args().collect::<Vec<_>>(), name, default)
}

/// Whether the bare option `name` (e.g. `--gpu`) is on the command line.
pub fn flag(name: &str) -> bool {
    std::env::args().any(|a| a == name)
}

/// [`arg`] over an explicit argument list.
fn arg_in<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> Result<T> {
    match args.iter().position(|a| a == name) {
        None => Ok(default),
        Some(i) => {
            let v = args.get(i + 1).map(String::as_str).unwrap_or("");
            v.parse().map_err(|_| {
                Error::invalid(
                    name,
                    v,
                    format!("could not parse it as {}", std::any::type_name::<T>()),
                )
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::arg_in;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(String::from).collect()
    }

    #[test]
    fn values_defaults_and_errors() {
        let a = args("prog --n 42 --dt 0.5 --bad x");
        assert_eq!(arg_in::<u32>(&a, "--n", 7).unwrap(), 42);
        assert_eq!(arg_in::<f64>(&a, "--dt", 1.0).unwrap(), 0.5);
        assert_eq!(arg_in::<u32>(&a, "--m", 7).unwrap(), 7);
        let e = arg_in::<u32>(&a, "--bad", 7).unwrap_err().to_string();
        assert!(
            e.contains("--bad") && e.contains('x') && e.contains("u32"),
            "{e}"
        );
        assert!(arg_in::<u32>(&args("prog --n"), "--n", 7).is_err());
    }
}
