//! The forced integrators against the exact linear flow and against each other.
