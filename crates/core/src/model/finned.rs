//! The finned AUV's parameter vector (seed 004): names and units, shared by the adaptive
//! identifier (`field::adaptive`) and the twin, which states its truth in them.

/// The parameters in order, with their units.
pub const NAMES: [(&str, &str); 20] = [
    ("m_u", "kg"),
    ("m_v", "kg"),
    ("m_w", "kg"),
    ("m_p", "kg m^2"),
    ("m_q", "kg m^2"),
    ("m_r", "kg m^2"),
    ("d_uu", "N s^2/m^2"),
    ("d_vv", "N s^2/m^2"),
    ("d_ww", "N s^2/m^2"),
    ("d_pp", "N m s^2"),
    ("d_qq", "N m s^2"),
    ("d_rr", "N m s^2"),
    ("W-B", "N"),
    ("B*x_B", "N m"),
    ("B*z_B", "N m"),
    ("k_T", "N s^2/rad^2"),
    ("c_L1", "N s^2/m^2"),
    ("c_L3", "N s^2/m^2"),
    ("c_D0", "N s^2/m^2"),
    ("c_D2", "N s^2/m^2"),
];
