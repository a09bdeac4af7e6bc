//! SPD-style procedural scene generators: each builds a [`parrt::description::SceneDescription`]
//! deterministically from a name and a size factor.
