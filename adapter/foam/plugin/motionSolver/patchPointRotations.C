/*---------------------------------------------------------------------------*\
    whale-adapter: the local rotation of every patch point
    (see patchPointRotations.H).

    The rotation is the unit eigenvector of the largest eigenvalue of a
    symmetric 4x4 matrix (Horn's quaternion), found by cyclic Jacobi.
\*---------------------------------------------------------------------------*/

#include "patchPointRotations.H"
#include "pointKdTree.H"
#include "DynamicList.H"
#include <cmath>

namespace
{

//- Unit eigenvector of the largest eigenvalue of the symmetric 4x4 matrix a
void largestEigenvector4(double a[4][4], double q[4])
{
    double v[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};

    for (int sweep = 0; sweep < 50; ++sweep)
    {
        double off = 0, diag = 0;
        for (int i = 0; i < 4; ++i)
        {
            diag += a[i][i] * a[i][i];
            for (int j = i + 1; j < 4; ++j)
            {
                off += a[i][j] * a[i][j];
            }
        }
        if (off <= 1e-30 * diag || off == 0)
        {
            break;
        }
        for (int p = 0; p < 3; ++p)
        {
            for (int r = p + 1; r < 4; ++r)
            {
                if (a[p][r] == 0)
                {
                    continue;
                }
                const double theta = (a[r][r] - a[p][p]) / (2 * a[p][r]);
                const double t = (theta >= 0 ? 1 : -1)
                    / (std::fabs(theta) + std::sqrt(theta * theta + 1));
                const double c = 1 / std::sqrt(t * t + 1);
                const double s = t * c;
                for (int k = 0; k < 4; ++k)
                {
                    const double akp = a[k][p], akr = a[k][r];
                    a[k][p] = c * akp - s * akr;
                    a[k][r] = s * akp + c * akr;
                }
                for (int k = 0; k < 4; ++k)
                {
                    const double apk = a[p][k], ark = a[r][k];
                    a[p][k] = c * apk - s * ark;
                    a[r][k] = s * apk + c * ark;
                }
                for (int k = 0; k < 4; ++k)
                {
                    const double vkp = v[k][p], vkr = v[k][r];
                    v[k][p] = c * vkp - s * vkr;
                    v[k][r] = s * vkp + c * vkr;
                }
            }
        }
    }

    int best = 0;
    for (int i = 1; i < 4; ++i)
    {
        if (a[i][i] > a[best][best])
        {
            best = i;
        }
    }
    double n = 0;
    for (int k = 0; k < 4; ++k)
    {
        q[k] = v[k][best];
        n += q[k] * q[k];
    }
    n = std::sqrt(n);
    for (int k = 0; k < 4; ++k)
    {
        q[k] /= n;
    }
}

} // End anonymous namespace


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::patchPointRotations::patchPointRotations(
    const pointKdTree& tree,
    const label K
)
{
    // Each patch point's K nearest patch points (itself excluded)
    std::vector<std::pair<scalar, label>> nearest;
    nbrOffsets_.setSize(tree.size() + 1);
    DynamicList<label> nbrs(tree.size() * K);
    nbrOffsets_[0] = 0;
    forAll(tree.points(), i)
    {
        tree.knn(tree.points()[i], K + 1, nearest);
        for (const auto& n : nearest)
        {
            if (n.second != i)
            {
                nbrs.append(n.second);
            }
        }
        nbrOffsets_[i + 1] = nbrs.size();
    }
    nbrs_.transfer(nbrs);
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

Foam::tmp<Foam::tensorField> Foam::patchPointRotations::rotations(
    const pointField& patchPoints0,
    const vectorField& d
) const
{
    tmp<tensorField> tR(new tensorField(patchPoints0.size(), I));
    tensorField& Rm = tR.ref();

    forAll(patchPoints0, j)
    {
        // S = sum a b^T
        tensor S(Zero);
        for (label k = nbrOffsets_[j]; k < nbrOffsets_[j + 1]; ++k)
        {
            const label n = nbrs_[k];
            const vector a(patchPoints0[n] - patchPoints0[j]);
            const vector b(a + d[n] - d[j]);
            S += a * b;
        }
        const scalar Sxx = S.xx(), Sxy = S.xy(), Sxz = S.xz();
        const scalar Syx = S.yx(), Syy = S.yy(), Syz = S.yz();
        const scalar Szx = S.zx(), Szy = S.zy(), Szz = S.zz();

        double N[4][4] = {
            {Sxx + Syy + Szz, Syz - Szy, Szx - Sxz, Sxy - Syx},
            {Syz - Szy, Sxx - Syy - Szz, Sxy + Syx, Szx + Sxz},
            {Szx - Sxz, Sxy + Syx, -Sxx + Syy - Szz, Syz + Szy},
            {Sxy - Syx, Szx + Sxz, Syz + Szy, -Sxx - Syy + Szz}
        };
        double q[4];
        largestEigenvector4(N, q);
        const double q0 = q[0], q1 = q[1], q2 = q[2], q3 = q[3];

        Rm[j] = tensor(
            1 - 2 * (q2 * q2 + q3 * q3),
            2 * (q1 * q2 - q0 * q3),
            2 * (q1 * q3 + q0 * q2),
            2 * (q1 * q2 + q0 * q3),
            1 - 2 * (q1 * q1 + q3 * q3),
            2 * (q2 * q3 - q0 * q1),
            2 * (q1 * q3 - q0 * q2),
            2 * (q2 * q3 + q0 * q1),
            1 - 2 * (q1 * q1 + q2 * q2)
        );
    }

    return tR;
}


// ************************************************************************* //
