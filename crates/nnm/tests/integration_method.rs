//! What an [`IntegrationMethod`] says of itself: its name is the spelling job files use, and
//! its properties are those of its family (docs/method.md §6).

use nnm::integrate::IntegrationMethod;
use serde::Deserialize;
use serde::de::IntoDeserializer;
use serde::de::value::Error;

#[test]
fn names_are_the_settings_spellings() {
    for method in IntegrationMethod::ALL {
        let parsed = IntegrationMethod::deserialize(IntoDeserializer::<Error>::into_deserializer(
            method.name(),
        ));
        assert_eq!(parsed, Ok(method), "{}", method.name());
    }
}

/// `ALL` holds every variant: a new one fails to compile here until it is listed, and then
/// this test until `ALL` lists it too.
#[test]
fn all_lists_every_method() {
    let listed = |m: IntegrationMethod| IntegrationMethod::ALL.contains(&m);
    for method in IntegrationMethod::ALL {
        match method {
            IntegrationMethod::Auto
            | IntegrationMethod::Dop853
            | IntegrationMethod::Dopri5
            | IntegrationMethod::Gauss4
            | IntegrationMethod::Gauss6
            | IntegrationMethod::Radau5
            | IntegrationMethod::Radau9 => {}
        }
    }
    for method in [
        IntegrationMethod::Auto,
        IntegrationMethod::Dop853,
        IntegrationMethod::Dopri5,
        IntegrationMethod::Gauss4,
        IntegrationMethod::Gauss6,
        IntegrationMethod::Radau5,
        IntegrationMethod::Radau9,
    ] {
        assert!(listed(method), "{}", method.name());
    }
}

#[test]
fn symplectic_and_damping_methods_are_collocation_methods() {
    for method in IntegrationMethod::ALL {
        if method.is_symplectic() || method.damps_unresolved_modes() {
            assert!(method.is_collocation(), "{}", method.name());
        }
        assert!(
            !(method.is_symplectic() && method.damps_unresolved_modes()),
            "{}",
            method.name()
        );
    }
    assert!(IntegrationMethod::Auto.is_auto());
    assert!(!IntegrationMethod::Auto.is_collocation());
}
