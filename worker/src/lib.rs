//! The parrt render worker: dials a master, authenticates, renders assigned tiles with rayon.
