//! A password given in the project (`password:`) or by an environment variable
//! (`password_env:`), as the services that log in (MQTT) or let clients log in (OPC UA) take it.

/// A password, kept out of `Debug` so a printed project does not leak it.
#[derive(Clone, PartialEq, Eq)]
pub struct Password(pub String);

impl std::fmt::Debug for Password {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Password(<hidden>)")
    }
}

/// Why `password:` / `password_env:` give no password.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum PasswordError {
    /// Both keys are set.
    Both,
    /// The variable is not set.
    Unset(String),
}

/// The password `password` (in clear) or `password_env` (a variable's name) gives; `None`
/// when neither is set.
pub(crate) fn password(
    password: &Option<String>,
    password_env: &Option<String>,
) -> Result<Option<Password>, PasswordError> {
    match (password, password_env) {
        (Some(_), Some(_)) => Err(PasswordError::Both),
        (Some(p), None) => Ok(Some(Password(p.clone()))),
        (None, Some(name)) => std::env::var(name)
            .map(|p| Some(Password(p)))
            .map_err(|_| PasswordError::Unset(name.clone())),
        (None, None) => Ok(None),
    }
}

/// [`password`] with its refusal as a service's own error at the key it names: `both` at
/// `password` when both keys are set, `unset(name)` at `password_env` when the variable is not
/// set. One mapping for every service that takes a password.
pub(crate) fn password_at<E>(
    given: &Option<String>,
    given_env: &Option<String>,
    both: E,
    unset: impl FnOnce(String) -> E,
) -> Result<Option<Password>, (&'static str, E)> {
    password(given, given_env).map_err(|e| match e {
        PasswordError::Both => ("password", both),
        PasswordError::Unset(name) => ("password_env", unset(name)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_refused_password_is_the_services_error_at_the_key_it_names() {
        let some = |s: &str| Some(s.to_string());
        let at = |p: &Option<String>, e: &Option<String>| {
            password_at(p, e, "both".to_string(), |name| format!("unset {name}"))
        };
        assert_eq!(
            at(&some("x"), &some("V")),
            Err(("password", "both".to_string()))
        );
        let unset = "SOFTPLC_TEST_PASSWORD_THAT_IS_NEVER_SET";
        assert_eq!(
            at(&None, &some(unset)),
            Err(("password_env", format!("unset {unset}")))
        );
        assert_eq!(at(&some("x"), &None), Ok(Some(Password("x".into()))));
        assert_eq!(at(&None, &None), Ok(None));
    }
}
