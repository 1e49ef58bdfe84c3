//! The mass matrix's positive definiteness (seed 003: M is positive definite) and its inverse
//! over the DOFs a vehicle moves in.

use super::Mat6;
use crate::dof::Dof;
use nalgebra::DMatrix;

/// The inverse of `m` over the `active` DOFs (zero elsewhere), or why it has none: the
/// smallest eigenvalue and its direction when `m` is not positive definite there.
pub fn inverse(m: &Mat6, active: &[bool; 6]) -> Result<Mat6, String> {
    let ix: Vec<usize> = (0..6).filter(|&i| active[i]).collect();
    let sub = DMatrix::from_fn(ix.len(), ix.len(), |a, b| m[ix[a]][ix[b]]);
    let eig = crate::numerics::symmetric_eigen(sub.clone())
        .ok_or("the matrix has an entry that is not a finite number")?;
    let (k, &low) = eig
        .eigenvalues
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.total_cmp(b.1))
        .ok_or("the vehicle has no DOFs")?;
    let chol = (low > 0.0).then(|| sub.cholesky()).flatten();
    let Some(chol) = chol else {
        let dir = eig.eigenvectors.column(k);
        let (at, _) = dir
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
            .unwrap();
        return Err(format!(
            "the mass matrix M_RB - M_A is not positive definite: its smallest eigenvalue is {low:.4} \
             (mostly {}), so the model would accelerate against the force it is given; it cannot \
             be simulated (fewer mass terms, or more excitation in {}, would help)",
            Dof::ALL[ix[at]],
            Dof::ALL[ix[at]]
        ));
    };
    let inv = chol.inverse();
    let mut out = [[0.0; 6]; 6];
    for (a, &i) in ix.iter().enumerate() {
        for (b, &j) in ix.iter().enumerate() {
            out[i][j] = inv[(a, b)];
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refuses_a_matrix_that_is_not_positive_definite() {
        let mut m = [[0.0; 6]; 6];
        for (i, row) in m.iter_mut().enumerate() {
            row[i] = 2.0;
        }
        let all = [true; 6];
        let inv = inverse(&m, &all).unwrap();
        assert!((inv[3][3] - 0.5).abs() < 1e-12);
        m[0][1] = 3.0;
        m[1][0] = 3.0;
        let err = inverse(&m, &all).unwrap_err();
        assert!(
            err.contains("not positive definite") && err.contains("-1.0000"),
            "{err}"
        );
        // The coupling is outside a surge-only vehicle's DOFs.
        let surge = [true, false, false, false, false, false];
        assert!(inverse(&m, &surge).is_ok());
    }
}
