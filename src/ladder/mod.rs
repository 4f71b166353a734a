//! Ladder of forward models behind one interface (constant curvature ... full Cosserat).
