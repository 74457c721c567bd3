/*---------------------------------------------------------------------------*\
    whale-adapter: the blending weights of whaleBlendedDisplacement
    (see patchBlendWeights.H)
\*---------------------------------------------------------------------------*/

#include "patchBlendWeights.H"
#include "pointKdTree.H"
#include "patchClusters.H"
#include "DynamicList.H"
#include "UIndirectList.H"
#include <algorithm>

namespace
{
//- Quintic smoothstep: 0 at s <= 0, 1 at s >= 1, C2
Foam::scalar smoothstep5(Foam::scalar s)
{
    s = std::min(std::max(s, Foam::scalar(0)), Foam::scalar(1));
    return s * s * s * (10 - 15 * s + 6 * s * s);
}


//- Append the normalised weights, times factor, of a point's K+1 nearest
//  sources (nearest first, squared distances) to sources/weights, the
//  sources' indices shifted by offset; areas: the sources' (with a shell);
//  r1: the point's distance to the patch, which the shell is measured from;
//  w: scratch space
void appendWeights(
    const std::vector<std::pair<Foam::scalar, Foam::label>>& nearest,
    const Foam::label K,
    const Foam::scalar power,
    const Foam::scalar shell,
    const Foam::scalar r1,
    const Foam::scalarField& areas,
    const Foam::label offset,
    const Foam::scalar factor,
    Foam::DynamicList<Foam::label>& sources,
    Foam::DynamicList<Foam::scalar>& weights,
    std::vector<Foam::scalar>& w
)
{
    using namespace Foam;
    w.assign(K, 0);
    const scalar rLast = Foam::sqrt(nearest[K].first);
    // A point of this rank that is a patch point of another rank's faces
    // only (r_1 = 0) follows that point: its weight is GREAT
    const scalar R =
        (shell > 0 && r1 > 0 ? std::min((1 + shell) * r1, rLast) : rLast);
    const scalar cut = Foam::pow(R, -power);
    scalar sumW = 0;
    for (label j = 0; j < K; ++j)
    {
        const scalar r = Foam::sqrt(nearest[j].first);
        w[j] = (r > 0 ? Foam::pow(r, -power) - cut : GREAT);
        if (shell > 0)
        {
            w[j] = std::max(w[j], scalar(0)) * areas[nearest[j].second];
        }
        sumW += w[j];
    }
    if (!(sumW > 0))
    {
        // All K + 1 equally far: plain average
        std::fill(w.begin(), w.end(), scalar(1));
        sumW = K;
    }
    for (label j = 0; j < K; ++j)
    {
        if (w[j] > 0)
        {
            sources.append(offset + nearest[j].second);
            weights.append(factor * w[j] / sumW);
        }
    }
}
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::patchBlendWeights::patchBlendWeights(
    const pointField& p0,
    const labelList& meshPoints,
    const pointKdTree& tree,
    const label K,
    const scalar power,
    const scalar innerDistance,
    const scalar outerDistance,
    const scalar rotationInner,
    const scalar rotationDistance,
    const scalar shell,
    const scalarField& areas,
    const patchClusters* clusters,
    const scalar fraction
) :
    nPatchPoints_(tree.size())
{
    if (shell > 0 && areas.size() != tree.size())
    {
        FatalErrorInFunction
            << "a shell needs the area of every patch point: got "
            << areas.size() << " areas for " << tree.size() << " points"
            << exit(FatalError);
    }
    if (clusters && !(shell > 0 && fraction > 0))
    {
        FatalErrorInFunction
            << "clusters need a shell > 0 and a fraction > 0: got shell "
            << shell << ", fraction " << fraction << exit(FatalError);
    }

    boolList onPatch(p0.size(), false);
    UIndirectList<bool>(onPatch, meshPoints) = true;

    DynamicList<label> blendPoints(p0.size());
    DynamicList<label> offsets(p0.size() + 1);
    DynamicList<label> sources(p0.size() * K);
    DynamicList<scalar> weights(p0.size() * K);
    DynamicList<scalar> psi(p0.size());
    offsets.append(0);

    std::vector<std::pair<scalar, label>> nearest;
    std::vector<std::pair<scalar, label>> nearestClusters;
    std::vector<scalar> w;
    const scalar R2 = sqr(outerDistance);

    forAll(p0, pointi)
    {
        if (onPatch[pointi])
        {
            continue;
        }
        tree.knn(p0[pointi], K + 1, nearest);
        const scalar r1sqr = nearest[0].first;
        if (r1sqr >= R2)
        {
            continue;
        }
        const scalar r1 = Foam::sqrt(r1sqr);
        const scalar phi =
            smoothstep5((outerDistance - r1) / (outerDistance - innerDistance));
        if (phi <= 0)
        {
            continue;
        }

        blendPoints.append(pointi);
        const scalar level = (clusters ? clusters->level(r1, fraction) : 0);
        const label top = (clusters ? clusters->nLevels() - 1 : 0);
        const label lo = std::min(label(level), std::max(top - 1, label(0)));
        const scalar beta = (top > 0 ? smoothstep5(level - lo) : 0);
        for (label l = lo; l <= lo + 1; ++l)
        {
            const scalar share = (l == lo ? 1 - beta : beta);
            if (share <= 0)
            {
                continue;
            }
            if (l == 0)
            {
                appendWeights(
                    nearest,
                    K,
                    power,
                    shell,
                    r1,
                    areas,
                    0,
                    phi * share,
                    sources,
                    weights,
                    w
                );
                continue;
            }
            const pointKdTree& level_tree = clusters->tree(l);
            const label Kl = std::min(K, level_tree.size() - 1);
            if (Kl < 1)
            {
                // One cluster: the whole patch's mean
                sources.append(clusters->offset(l));
                weights.append(phi * share);
                continue;
            }
            level_tree.knn(p0[pointi], Kl + 1, nearestClusters);
            appendWeights(
                nearestClusters,
                Kl,
                power,
                shell,
                r1,
                clusters->areas(l),
                clusters->offset(l),
                phi * share,
                sources,
                weights,
                w
            );
        }
        offsets.append(sources.size());
        psi.append(smoothstep5(
            (rotationDistance - r1) / (rotationDistance - rotationInner)
        ));
    }

    points_.transfer(blendPoints);
    offsets_.transfer(offsets);
    sources_.transfer(sources);
    weights_.transfer(weights);
    psi_.transfer(psi);
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void Foam::patchBlendWeights::apply(const vectorField& d, vectorField& pd) const
{
    forAll(points_, i)
    {
        vector sum(Zero);
        for (label k = offsets_[i]; k < offsets_[i + 1]; ++k)
        {
            sum += weights_[k] * d[sources_[k]];
        }
        pd[points_[i]] = sum;
    }
}


void Foam::patchBlendWeights::apply(
    const vectorField& d,
    const tensorField& Rm,
    const pointField& p0,
    const pointField& patchPoints0,
    vectorField& pd
) const
{
    forAll(points_, i)
    {
        const label pointi = points_[i];
        const point& x = p0[pointi];
        vector sum(Zero);
        if (psi_[i] > 0)
        {
            for (label k = offsets_[i]; k < offsets_[i + 1]; ++k)
            {
                const label j = sources_[k];
                if (j < nPatchPoints_)
                {
                    sum += weights_[k]
                        * (d[j]
                           + psi_[i] * ((Rm[j] - I) & (x - patchPoints0[j])));
                }
                else
                {
                    // a cluster: the rotation acts through the points alone
                    sum += weights_[k] * d[j];
                }
            }
        }
        else
        {
            // beyond rotationDistance: the displacements alone
            for (label k = offsets_[i]; k < offsets_[i + 1]; ++k)
            {
                sum += weights_[k] * d[sources_[k]];
            }
        }
        pd[pointi] = sum;
    }
}


// ************************************************************************* //
