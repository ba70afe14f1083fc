//! Errors of a chain's or a scene's specification, naming the field, and the checks every
//! specification shares.

/// Error in a chain or physics specification, naming the field.
#[derive(Debug, Clone, PartialEq)]
pub struct SpecError {
    /// Dotted path of the offending field.
    pub field: String,
    /// What is allowed.
    pub message: String,
}

impl std::fmt::Display for SpecError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.field, self.message)
    }
}

impl std::error::Error for SpecError {}

/// A [`SpecError`] naming `field`.
pub fn spec_err(field: &str, message: impl Into<String>) -> SpecError {
    SpecError {
        field: field.to_string(),
        message: message.into(),
    }
}

/// `v` must be a finite number > 0; the error names `field`.
pub fn check_positive(field: &str, v: f64) -> Result<(), SpecError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(spec_err(
            field,
            format!("must be a finite number > 0, got {v}"),
        ))
    }
}
