//! Mailboxing without per-ray allocation: a small direct-mapped set of the primitive indices one
//! ray has already tested, living on the stack. A primitive that spans several cells is tested
//! once; a collision only evicts an entry, which costs a repeated (harmless) test, never a
//! skipped one.

/// Slots of the mailbox (a power of two).
pub const MAILBOX_SLOTS: usize = 64;

/// The per-ray set of tested primitives.
#[derive(Clone, Debug)]
pub struct Mailbox {
    slots: [u32; MAILBOX_SLOTS],
}

impl Default for Mailbox {
    fn default() -> Self {
        Self::new()
    }
}

impl Mailbox {
    /// An empty mailbox.
    #[inline(always)]
    pub fn new() -> Self {
        Mailbox {
            slots: [u32::MAX; MAILBOX_SLOTS],
        }
    }

    /// Records `prim` and returns true when it was not recorded yet (so it must be tested).
    /// `u32::MAX` is the empty marker and therefore always reported as new.
    #[inline(always)]
    pub fn first_visit(&mut self, prim: u32) -> bool {
        let slot = &mut self.slots[prim as usize & (MAILBOX_SLOTS - 1)];
        if *slot == prim && prim != u32::MAX {
            false
        } else {
            *slot = prim;
            true
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remembers_and_evicts() {
        let mut m = Mailbox::new();
        assert!(m.first_visit(3));
        assert!(!m.first_visit(3));
        assert!(m.first_visit(3 + MAILBOX_SLOTS as u32));
        // Evicted by the collision: tested again, which is allowed.
        assert!(m.first_visit(3));
        assert!(m.first_visit(u32::MAX));
        assert!(m.first_visit(u32::MAX));
    }
}
