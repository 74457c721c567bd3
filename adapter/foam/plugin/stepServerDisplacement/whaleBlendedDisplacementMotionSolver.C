/*---------------------------------------------------------------------------*\
    whale-adapter: whaleBlendedDisplacement motion solver
    (see whaleBlendedDisplacementMotionSolver.H)
\*---------------------------------------------------------------------------*/

#include "whaleBlendedDisplacementMotionSolver.H"
#include "pointKdTree.H"
#include "addToRunTimeSelectionTable.H"
#include "pointConstraints.H"
#include "mapPolyMesh.H"
#include "Pstream.H"
#include <algorithm>
#include <numeric>

namespace Foam
{
    defineTypeNameAndDebug(whaleBlendedDisplacementMotionSolver, 0);
    addToRunTimeSelectionTable
    (
        motionSolver,
        whaleBlendedDisplacementMotionSolver,
        dictionary
    );
    addToRunTimeSelectionTable
    (
        displacementMotionSolver,
        whaleBlendedDisplacementMotionSolver,
        displacement
    );
}


namespace
{
    //- Quintic smoothstep: 0 at s <= 0, 1 at s >= 1, C2
    Foam::scalar smoothstep5(Foam::scalar s)
    {
        s = std::min(std::max(s, Foam::scalar(0)), Foam::scalar(1));
        return s*s*s*(10 - 15*s + 6*s*s);
    }
}


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

void Foam::whaleBlendedDisplacementMotionSolver::readCoeffs()
{
    const dictionary& dict = coeffDict();
    const word patchName(dict.getOrDefault<word>("patch", "whale"));
    patchi_ = mesh().boundaryMesh().findPatchID(patchName);
    if (patchi_ < 0)
    {
        FatalIOErrorInFunction(dict)
            << "patch " << patchName << " not found; patches: "
            << mesh().boundaryMesh().names() << exit(FatalIOError);
    }
    nNeighbours_ = dict.getOrDefault<label>("nNeighbours", 16);
    power_ = dict.getOrDefault<scalar>("power", 3);
    innerDistance_ = dict.getOrDefault<scalar>("innerDistance", 0.5);
    outerDistance_ = dict.get<scalar>("outerDistance");
    rotation_ = dict.getOrDefault<bool>("rotation", false);
    rotationDistance_ = dict.getOrDefault<scalar>("rotationDistance", 2);

    if
    (
        nNeighbours_ < 1 || power_ <= 0 || innerDistance_ < 0
     || outerDistance_ <= innerDistance_
     || rotationDistance_ <= innerDistance_
    )
    {
        FatalIOErrorInFunction(dict)
            << "need nNeighbours >= 1, power > 0, 0 <= innerDistance"
            << " < outerDistance, innerDistance < rotationDistance; got nNeighbours "
            << nNeighbours_ << ", power " << power_ << ", innerDistance "
            << innerDistance_ << ", outerDistance " << outerDistance_
            << ", rotationDistance " << rotationDistance_
            << exit(FatalIOError);
    }
}


void Foam::whaleBlendedDisplacementMotionSolver::calcWeights()
{
    const polyPatch& pp = mesh().boundaryMesh()[patchi_];
    const labelList& meshPoints = pp.meshPoints();
    const pointField& p0 = points0();

    // Every rank's patch points, undeformed
    List<pointField> allPts(Pstream::nProcs());
    allPts[Pstream::myProcNo()] = pointField(p0, meshPoints);
    Pstream::gatherList(allPts);
    Pstream::scatterList(allPts);

    label nAll = 0;
    forAll(allPts, proci)
    {
        nAll += allPts[proci].size();
    }
    pointField all(nAll);
    {
        label k = 0;
        forAll(allPts, proci)
        {
            for (const point& x : allPts[proci])
            {
                all[k++] = x;
            }
        }
    }

    // Sort lexicographically, merge exact duplicates: independent of the
    // decomposition
    labelList order(nAll);
    std::iota(order.begin(), order.end(), 0);
    auto less = [&all](label a, label b)
    {
        const point& pa = all[a];
        const point& pb = all[b];
        if (pa.x() != pb.x()) return pa.x() < pb.x();
        if (pa.y() != pb.y()) return pa.y() < pb.y();
        return pa.z() < pb.z();
    };
    std::stable_sort(order.begin(), order.end(), less);

    labelList slotOf(nAll);
    DynamicList<point> merged(nAll);
    forAll(order, i)
    {
        const label a = order[i];
        if (i == 0 || all[a] != all[order[i - 1]])
        {
            merged.append(all[a]);
        }
        slotOf[a] = merged.size() - 1;
    }
    patchPoints0_.transfer(merged);

    slots_.setSize(Pstream::nProcs());
    {
        label k = 0;
        forAll(allPts, proci)
        {
            slots_[proci].setSize(allPts[proci].size());
            forAll(allPts[proci], i)
            {
                slots_[proci][i] = slotOf[k++];
            }
        }
    }

    const pointKdTree tree(patchPoints0_);
    const label K = std::min(nNeighbours_, tree.size() - 1);
    if (K < 1)
    {
        FatalErrorInFunction
            << "patch " << pp.name() << " has " << tree.size()
            << " points: need at least 2" << exit(FatalError);
    }

    // Blend weights of every mesh point off the patch within outerDistance
    boolList onPatch(p0.size(), false);
    UIndirectList<bool>(onPatch, meshPoints) = true;

    DynamicList<label> blendPoints(p0.size());
    DynamicList<label> offsets(p0.size() + 1);
    DynamicList<label> sources(p0.size()*K);
    DynamicList<scalar> weights(p0.size()*K);
    DynamicList<scalar> psi(p0.size());
    offsets.append(0);

    std::vector<std::pair<scalar, label>> nearest;
    const scalar R2 = sqr(outerDistance_);
    std::vector<scalar> w(K + 1);

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
        const scalar phi = smoothstep5
        (
            (outerDistance_ - r1)/(outerDistance_ - innerDistance_)
        );
        if (phi <= 0)
        {
            continue;
        }

        const scalar rLast = Foam::sqrt(nearest[K].first);
        const scalar cut = Foam::pow(rLast, -power_);
        scalar sumW = 0;
        for (label j = 0; j < K; ++j)
        {
            const scalar r = Foam::sqrt(nearest[j].first);
            w[j] = (r > 0 ? Foam::pow(r, -power_) - cut : GREAT);
            sumW += w[j];
        }
        if (!(sumW > 0))
        {
            // All K + 1 equally far: plain average
            for (label j = 0; j < K; ++j)
            {
                w[j] = 1;
            }
            sumW = K;
        }

        blendPoints.append(pointi);
        for (label j = 0; j < K; ++j)
        {
            if (w[j] > 0)
            {
                sources.append(nearest[j].second);
                weights.append(phi*w[j]/sumW);
            }
        }
        offsets.append(sources.size());
        psi.append
        (
            smoothstep5
            (
                (rotationDistance_ - r1)/(rotationDistance_ - innerDistance_)
            )
        );
    }

    blendPoints_.transfer(blendPoints);
    offsets_.transfer(offsets);
    sources_.transfer(sources);
    weights_.transfer(weights);
    psi_.transfer(psi);

    if (rotation_)
    {
        // Each patch point's K nearest patch points (itself excluded)
        nbrOffsets_.setSize(tree.size() + 1);
        DynamicList<label> nbrs(tree.size()*K);
        nbrOffsets_[0] = 0;
        forAll(patchPoints0_, i)
        {
            tree.knn(patchPoints0_[i], K + 1, nearest);
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

    Info<< typeName << ": patch " << pp.name() << " "
        << patchPoints0_.size() << " points (merged from " << nAll
        << " over " << Pstream::nProcs() << " rank(s)); "
        << returnReduce(blendPoints_.size(), sumOp<label>())
        << " mesh points blended (K " << K << ", power " << power_
        << ", innerDistance " << innerDistance_ << ", outerDistance "
        << outerDistance_ << ", rotation " << rotation_ << ")" << endl;
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::whaleBlendedDisplacementMotionSolver::whaleBlendedDisplacementMotionSolver
(
    const polyMesh& mesh,
    const IOdictionary& dict
)
:
    displacementMotionSolver(mesh, dict, typeName)
{
    readCoeffs();
    calcWeights();
}


Foam::whaleBlendedDisplacementMotionSolver::whaleBlendedDisplacementMotionSolver
(
    const polyMesh& mesh,
    const IOdictionary& dict,
    const pointVectorField& pointDisplacement,
    const pointIOField& points0
)
:
    displacementMotionSolver(mesh, dict, pointDisplacement, points0, typeName)
{
    readCoeffs();
    calcWeights();
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

Foam::tmp<Foam::pointField>
Foam::whaleBlendedDisplacementMotionSolver::curPoints() const
{
    tmp<pointField> tcurPoints
    (
        points0() + pointDisplacement_.primitiveField()
    );
    twoDCorrectPoints(tcurPoints.ref());
    return tcurPoints;
}


void Foam::whaleBlendedDisplacementMotionSolver::solve()
{
    // The whale's condition asks the step-server (once per time)
    pointDisplacement_.boundaryFieldRef().updateCoeffs();

    const vectorField d(mergedPatchDisplacement());
    vectorField& pd = pointDisplacement_.primitiveFieldRef();

    // Only the patch's own points and the blended ones move
    pd = Zero;

    if (rotation_)
    {
        const tensorField Rm(patchRotations(d));
        const pointField& p0 = points0();
        forAll(blendPoints_, i)
        {
            const label pointi = blendPoints_[i];
            const point& x = p0[pointi];
            vector sum(Zero);
            for (label k = offsets_[i]; k < offsets_[i + 1]; ++k)
            {
                const label j = sources_[k];
                sum += weights_[k]
                   *(d[j] + psi_[i]*((Rm[j] - I) & (x - patchPoints0_[j])));
            }
            pd[pointi] = sum;
        }
    }
    else
    {
        forAll(blendPoints_, i)
        {
            vector sum(Zero);
            for (label k = offsets_[i]; k < offsets_[i + 1]; ++k)
            {
                sum += weights_[k]*d[sources_[k]];
            }
            pd[blendPoints_[i]] = sum;
        }
    }

    // The patch itself (evaluate() of its condition, no new request), the
    // other patches' conditions (slip: projected), points on several
    // constrained patches
    pointConstraints::New(pointDisplacement_.mesh()).constrainDisplacement
    (
        pointDisplacement_,
        false
    );
}


void Foam::whaleBlendedDisplacementMotionSolver::updateMesh
(
    const mapPolyMesh&
)
{
    FatalErrorInFunction
        << typeName << " does not support topology changes"
        << exit(FatalError);
}


// ************************************************************************* //
