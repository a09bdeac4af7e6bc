//! Teapot control data.
