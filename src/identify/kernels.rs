//! The equation-error objectives' inner loops, for a whole population at once: particles
//! stored transposed (p x m) so the particle loop vectorises, register-blocked, compiled for
//! AVX-512 and AVX2 and chosen at run time.

// Numeric kernels index several arrays with one loop variable; iterators would hide that.
#![allow(clippy::needless_range_loop)]

/// q[i] += x_i' A x_i - 2 b.x_i for every particle i (x stored transposed, p x m).
pub fn quad_all(a: &[f64], b: &[f64], xt: &[f64], p: usize, q: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("fma")
    {
        // SAFETY: the CPU has just been checked for the features the function is compiled with.
        unsafe { quad_all_avx512(a, b, xt, p, q) };
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: as above.
        unsafe { quad_all_avx2(a, b, xt, p, q) };
        return;
    }
    quad_all_generic::<false>(a, b, xt, p, q);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,fma")]
fn quad_all_avx512(a: &[f64], b: &[f64], xt: &[f64], p: usize, q: &mut [f64]) {
    quad_all_generic::<true>(a, b, xt, p, q);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn quad_all_avx2(a: &[f64], b: &[f64], xt: &[f64], p: usize, q: &mut [f64]) {
    quad_all_generic::<true>(a, b, xt, p, q);
}

/// Particles in groups of eight (then one), four rows of A at a time: t_k = (A x)_{r+k} - 2 b_{r+k}
/// stays in registers across the p columns, each loaded parameter feeds four multiply-adds.
#[inline(always)]
fn quad_all_generic<const FMA: bool>(a: &[f64], b: &[f64], xt: &[f64], p: usize, q: &mut [f64]) {
    let m = q.len();
    let mut g = 0;
    while g + 8 <= m {
        quad_group::<FMA, 8>(a, b, xt, p, q, g);
        g += 8;
    }
    while g < m {
        quad_group::<FMA, 1>(a, b, xt, p, q, g);
        g += 1;
    }
}

#[inline(always)]
fn quad_group<const FMA: bool, const G: usize>(
    a: &[f64],
    b: &[f64],
    xt: &[f64],
    p: usize,
    q: &mut [f64],
    g: usize,
) {
    let m = q.len();
    let fma = |x: f64, y: f64, z: f64| if FMA { x.mul_add(y, z) } else { x * y + z };
    let col =
        |j: usize| -> &[f64; G] { xt[j * m + g..j * m + g + G].try_into().expect("G columns") };
    let mut out = [0.0f64; G];
    let mut r = 0;
    while r + 4 <= p {
        let mut t = [[0.0f64; G]; 4];
        for k in 0..4 {
            t[k] = [-2.0 * b[r + k]; G];
        }
        for s in 0..p {
            let x = col(s);
            for k in 0..4 {
                let ars = a[(r + k) * p + s];
                for l in 0..G {
                    t[k][l] = fma(ars, x[l], t[k][l]);
                }
            }
        }
        for k in 0..4 {
            let x = col(r + k);
            for l in 0..G {
                out[l] = fma(x[l], t[k][l], out[l]);
            }
        }
        r += 4;
    }
    while r < p {
        let mut t = [-2.0 * b[r]; G];
        for s in 0..p {
            let (x, ars) = (col(s), a[r * p + s]);
            for l in 0..G {
                t[l] = fma(ars, x[l], t[l]);
            }
        }
        let x = col(r);
        for l in 0..G {
            out[l] = fma(x[l], t[l], out[l]);
        }
        r += 1;
    }
    for (o, v) in q[g..g + G].iter_mut().zip(out) {
        *o += v;
    }
}

/// Adds sum |row . x_i - y| over a block of rows to `acc[i]` for every particle i, the rows
/// and targets already multiplied by their weights.
pub fn l1_block(phi: &[f64], y: &[f64], xt: &[f64], p: usize, acc: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx512f") && std::arch::is_x86_feature_detected!("fma")
    {
        // SAFETY: the CPU has just been checked for the features the function is compiled with.
        unsafe { l1_block_avx512(phi, y, xt, p, acc) };
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU has just been checked for the features the function is compiled with.
        unsafe { l1_block_avx2(phi, y, xt, p, acc) };
        return;
    }
    l1_block_generic::<false, 4, 8, 4>(phi, y, xt, p, acc);
}

/// 32 vector registers of 8 lanes: 4 rows x 16 particles = 8 accumulators.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,fma")]
fn l1_block_avx512(phi: &[f64], y: &[f64], xt: &[f64], p: usize, acc: &mut [f64]) {
    l1_block_generic::<true, 4, 16, 8>(phi, y, xt, p, acc);
}

/// 16 vector registers of 4 lanes: 6 rows x 8 particles = 12 accumulators, 2 particle loads
/// and a broadcast in flight, no spills.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn l1_block_avx2(phi: &[f64], y: &[f64], xt: &[f64], p: usize, acc: &mut [f64]) {
    l1_block_generic::<true, 6, 8, 4>(phi, y, xt, p, acc);
}

/// Inlined into each caller so the particle loop is vectorised for the caller's features;
/// `FMA` only where the hardware has it (a software fused multiply-add is slow).
/// Register-blocked: R rows against G particles at a time (then G2, then one), the partial
/// fits kept in registers across the p columns, so each loaded parameter feeds R
/// multiply-adds and each broadcast row entry G. The fit starts at -y, so the residual costs
/// nothing beyond the p multiply-adds but its absolute value and the sum.
#[inline(always)]
fn l1_block_generic<const FMA: bool, const R: usize, const G: usize, const G2: usize>(
    phi: &[f64],
    y: &[f64],
    xt: &[f64],
    p: usize,
    acc: &mut [f64],
) {
    let rows = y.len();
    let mut i = 0;
    while i + R <= rows {
        l1_tile::<FMA, R, G, G2>(phi, y, xt, p, acc, i);
        i += R;
    }
    while i < rows {
        l1_tile::<FMA, 1, G, G2>(phi, y, xt, p, acc, i);
        i += 1;
    }
}

#[inline(always)]
fn l1_tile<const FMA: bool, const R: usize, const G: usize, const G2: usize>(
    phi: &[f64],
    y: &[f64],
    xt: &[f64],
    p: usize,
    acc: &mut [f64],
    i: usize,
) {
    let m = acc.len();
    let mut g = 0;
    while g + G <= m {
        l1_kernel::<FMA, R, G>(phi, y, xt, p, acc, i, g);
        g += G;
    }
    while g + G2 <= m {
        l1_kernel::<FMA, R, G2>(phi, y, xt, p, acc, i, g);
        g += G2;
    }
    while g < m {
        l1_kernel::<FMA, R, 1>(phi, y, xt, p, acc, i, g);
        g += 1;
    }
}

/// |row . x - y| for rows i..i+R and particles g..g+G, added to acc.
#[inline(always)]
fn l1_kernel<const FMA: bool, const R: usize, const G: usize>(
    phi: &[f64],
    y: &[f64],
    xt: &[f64],
    p: usize,
    acc: &mut [f64],
    i: usize,
    g: usize,
) {
    let m = acc.len();
    let mut f = [[0.0f64; G]; R];
    for r in 0..R {
        f[r] = [-y[i + r]; G];
    }
    for j in 0..p {
        let x: &[f64; G] = xt[j * m + g..j * m + g + G].try_into().expect("G columns");
        for r in 0..R {
            let a = phi[(i + r) * p + j];
            for l in 0..G {
                f[r][l] = if FMA {
                    a.mul_add(x[l], f[r][l])
                } else {
                    f[r][l] + a * x[l]
                };
            }
        }
    }
    let out: &mut [f64; G] = (&mut acc[g..g + G]).try_into().expect("G columns");
    for r in 0..R {
        for l in 0..G {
            out[l] += f[r][l].abs();
        }
    }
}
