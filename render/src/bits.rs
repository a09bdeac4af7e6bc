//! The set bits of a lane mask, lowest first: `for i in SetBits(mask)` walks the rays or lanes
//! a mask names (the `trailing_zeros` / clear-lowest-bit loop, written once).

/// An iterator over the indices of the set bits of a `u32`, lowest first.
#[derive(Clone, Copy, Debug)]
pub struct SetBits(pub u32);

impl Iterator for SetBits {
    type Item = usize;

    #[inline(always)]
    fn next(&mut self) -> Option<usize> {
        if self.0 == 0 {
            return None;
        }
        let i = self.0.trailing_zeros() as usize;
        self.0 &= self.0 - 1;
        Some(i)
    }
}

#[cfg(test)]
mod tests {
    use super::SetBits;

    #[test]
    fn walks_the_set_bits_lowest_first() {
        assert_eq!(SetBits(0).collect::<Vec<_>>(), Vec::<usize>::new());
        assert_eq!(SetBits(0b1010_0001).collect::<Vec<_>>(), vec![0, 5, 7]);
        assert_eq!(SetBits(1 << 31).collect::<Vec<_>>(), vec![31]);
    }
}
