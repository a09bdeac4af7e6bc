//! The generators against SPD's own outputs, one test binary: the files themselves, read with
//! parrt's parser ([`files`]), and the README's tables of them ([`readme`]).

mod files;
mod readme;
