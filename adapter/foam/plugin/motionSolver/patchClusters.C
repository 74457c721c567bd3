/*---------------------------------------------------------------------------*\
    whale-adapter: the patch points' clusters (see patchClusters.H)
\*---------------------------------------------------------------------------*/

#include "patchClusters.H"
#include "boundBox.H"
#include <algorithm>
#include <array>
#include <vector>

// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::patchClusters::patchClusters(
    const pointField& points,
    const scalarField& areas
) :
    nPoints_(points.size()),
    h1_(0),
    pointAreas_(areas)
{
    if (areas.size() != points.size() || points.size() < 2 || min(areas) <= 0)
    {
        FatalErrorInFunction
            << "clusters need at least 2 points and a positive area for each:"
            << " got " << points.size() << " points and " << areas.size()
            << " areas" << exit(FatalError);
    }

    // h_1: twice the median nearest-neighbour distance
    {
        const pointKdTree tree(points);
        std::vector<std::pair<scalar, label>> nearest;
        std::vector<scalar> spacing(points.size());
        forAll(points, i)
        {
            tree.knn(points[i], 2, nearest);
            spacing[i] = Foam::sqrt(nearest[1].first);
        }
        std::nth_element(
            spacing.begin(),
            spacing.begin() + spacing.size() / 2,
            spacing.end()
        );
        h1_ = 2 * std::max(spacing[spacing.size() / 2], SMALL);
    }

    const boundBox bb(points, false);
    const scalar extent = std::max(cmptMax(bb.span()), h1_);
    // Levels up to the first whose cubes hold the whole patch
    const label nClusterLevels =
        1 + label(std::ceil(std::log2(extent / h1_) - SMALL));

    cluster_.setSize(nClusterLevels);
    areas_.setSize(nClusterLevels);
    trees_.setSize(nClusterLevels);
    offsets_.setSize(nClusterLevels + 2);
    offsets_[0] = 0;
    offsets_[1] = nPoints_;

    typedef std::array<long, 3> cube;
    std::vector<cube> keys(points.size());
    std::vector<label> order(points.size());
    for (label l = 1; l <= nClusterLevels; ++l)
    {
        const scalar h = side(l);
        forAll(points, i)
        {
            const vector x((points[i] - bb.min()) / h);
            keys[i] = {long(x.x()), long(x.y()), long(x.z())};
            order[i] = i;
        }
        std::sort(
            order.begin(),
            order.end(),
            [&keys](label a, label b)
            {
                return keys[a] < keys[b] || (keys[a] == keys[b] && a < b);
            }
        );

        labelList& member = cluster_[l - 1];
        member.setSize(points.size());
        label n = 0;
        for (label k = 0; k < label(order.size()); ++k)
        {
            if (k > 0 && keys[order[k]] != keys[order[k - 1]])
            {
                ++n;
            }
            member[order[k]] = n;
        }
        ++n;

        scalarField& a = areas_[l - 1];
        a.setSize(n, Zero);
        pointField centres(n, Zero);
        forAll(points, i)
        {
            a[member[i]] += areas[i];
            centres[member[i]] += areas[i] * points[i];
        }
        centres /= a;
        trees_.set(l - 1, new pointKdTree(centres));
        offsets_[l + 1] = offsets_[l] + n;
    }
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

Foam::scalar Foam::patchClusters::side(const label l) const
{
    return l == 0 ? scalar(0) : h1_ * Foam::pow(scalar(2), scalar(l - 1));
}


Foam::scalar Foam::patchClusters::level(const scalar r1, const scalar fraction)
    const
{
    // side(l) = fraction r1 at l = log2(fraction r1 / h_1) + 1
    const scalar s = fraction * r1 / h1_;
    const scalar l = (s > 0 ? std::log2(s) + 1 : scalar(0));
    return std::min(std::max(l, scalar(0)), scalar(nLevels() - 1));
}


Foam::tmp<Foam::vectorField> Foam::patchClusters::sources(const vectorField& d
) const
{
    tmp<vectorField> tall(new vectorField(offsets_.last(), Zero));
    vectorField& all = tall.ref();
    forAll(d, i)
    {
        all[i] = d[i];
    }
    forAll(cluster_, lm1)
    {
        const labelList& member = cluster_[lm1];
        const scalarField& a = areas_[lm1];
        const label start = offsets_[lm1 + 1];
        forAll(member, i)
        {
            all[start + member[i]] += pointAreas_[i] * d[i];
        }
        forAll(a, c)
        {
            all[start + c] /= a[c];
        }
    }
    return tall;
}


// ************************************************************************* //
