/*---------------------------------------------------------------------------*\
    whale-adapter: whaleBlendedDisplacement motion solver
    (see whaleBlendedDisplacementMotionSolver.H)
\*---------------------------------------------------------------------------*/

#include "whaleBlendedDisplacementMotionSolver.H"
#include "pointKdTree.H"
#include "common/gamgRestartOrder.H"
#include "addToRunTimeSelectionTable.H"
#include "pointConstraints.H"
#include "valuePointPatchField.H"
#include "mapPolyMesh.H"
#include "Pstream.H"
#include <algorithm>

namespace Foam
{
defineTypeNameAndDebug(whaleBlendedDisplacementMotionSolver, 0);
addToRunTimeSelectionTable(
    motionSolver,
    whaleBlendedDisplacementMotionSolver,
    dictionary
);
addToRunTimeSelectionTable(
    displacementMotionSolver,
    whaleBlendedDisplacementMotionSolver,
    displacement
);
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
            << "patch " << patchName
            << " not found; patches: " << mesh().boundaryMesh().names()
            << exit(FatalIOError);
    }
    nNeighbours_ = dict.getOrDefault<label>("nNeighbours", 16);
    power_ = dict.getOrDefault<scalar>("power", 3);
    innerDistance_ = dict.getOrDefault<scalar>("innerDistance", 0.5);
    outerDistance_ = dict.get<scalar>("outerDistance");
    rotation_ = dict.getOrDefault<bool>("rotation", false);
    rotationNeighbours_ =
        dict.getOrDefault<label>("rotationNeighbours", nNeighbours_);
    rotationInner_ = dict.getOrDefault<scalar>("rotationInner", innerDistance_);
    rotationDistance_ = dict.getOrDefault<scalar>("rotationDistance", 2);
    shell_ = dict.getOrDefault<scalar>("shell", 0);
    clusterFraction_ = dict.getOrDefault<scalar>("clusters", 0);
    checkMotion_ = dict.getOrDefault<bool>("checkMotion", true);

    if (nNeighbours_ < 1 || (rotation_ && rotationNeighbours_ < 3)
        || power_ <= 0 || innerDistance_ < 0 || outerDistance_ <= innerDistance_
        || rotationInner_ < 0 || rotationDistance_ <= rotationInner_
        || shell_ < 0 || clusterFraction_ < 0
        || (clusterFraction_ > 0 && !(shell_ > 0)))
    {
        FatalIOErrorInFunction(dict)
            << "need nNeighbours >= 1, rotationNeighbours >= 3, power > 0,"
            << " 0 <= innerDistance"
            << " < outerDistance, 0 <= rotationInner < rotationDistance,"
               " shell >= 0, clusters >= 0 (> 0 only with a shell > 0);"
               " got nNeighbours "
            << nNeighbours_ << ", rotationNeighbours " << rotationNeighbours_
            << ", power " << power_ << ", innerDistance " << innerDistance_
            << ", outerDistance " << outerDistance_ << ", rotationInner "
            << rotationInner_ << ", rotationDistance " << rotationDistance_
            << ", shell " << shell_ << ", clusters " << clusterFraction_
            << exit(FatalIOError);
    }
}


void Foam::whaleBlendedDisplacementMotionSolver::calcWeights()
{
    const polyPatch& pp = mesh().boundaryMesh()[patchi_];
    const labelList& meshPoints = pp.meshPoints();
    const pointField& p0 = points0();

    patchPoints_.reset(new mergedPatchPoints(pointField(p0, meshPoints)));

    const pointKdTree tree(patchPoints_->points());
    const label K = std::min(nNeighbours_, tree.size() - 1);
    if (K < 1)
    {
        FatalErrorInFunction << "patch " << pp.name() << " has " << tree.size()
                             << " points: need at least 2" << exit(FatalError);
    }

    // With a shell: each patch point's area, a share of every face around it
    // (undeformed), summed over the ranks
    scalarField areas;
    if (shell_ > 0)
    {
        const pointField localPoints0(p0, meshPoints);
        scalarField mine(meshPoints.size(), Zero);
        for (const face& f : pp.localFaces())
        {
            const scalar share = f.mag(localPoints0) / f.size();
            for (const label pointi : f)
            {
                mine[pointi] += share;
            }
        }
        areas = patchPoints_->mergeSum(mine);
    }
    if (clusterFraction_ > 0)
    {
        clusters_.reset(new patchClusters(patchPoints_->points(), areas));
    }

    // Blend weights of every mesh point off the patch within outerDistance
    weights_.reset(new patchBlendWeights(
        p0,
        meshPoints,
        tree,
        K,
        power_,
        innerDistance_,
        outerDistance_,
        rotationInner_,
        rotationDistance_,
        shell_,
        areas,
        clusters_.get(),
        clusterFraction_
    ));

    if (rotation_)
    {
        rotations_.reset(new patchPointRotations(
            tree,
            std::min(rotationNeighbours_, tree.size() - 1)
        ));
    }

    Info << typeName << ": patch " << pp.name() << " "
         << patchPoints_->points().size() << " points (merged from "
         << patchPoints_->nGathered() << " over " << Pstream::nProcs()
         << " rank(s)); " << returnReduce(weights_->size(), sumOp<label>())
         << " mesh points blended (K " << K << ", power " << power_
         << ", innerDistance " << innerDistance_ << ", outerDistance "
         << outerDistance_ << ", rotation " << rotation_;
    if (rotation_)
    {
        Info << " (" << rotationInner_ << " to " << rotationDistance_
             << " m, fitted to " << rotationNeighbours_ << " points)";
    }
    Info << ", shell " << shell_;
    if (clusters_.valid())
    {
        Info << ", clusters " << clusterFraction_ << " ("
             << clusters_->nLevels() - 1 << " levels from "
             << clusters_->side(1) << " m)";
    }
    Info << ", checkMotion " << checkMotion_ << ")" << endl;

    if (checkMotion_)
    {
        motionCheck_.reset(new meshMotionCheck(mesh(), typeName));
    }
}


Foam::tmp<Foam::vectorField>
Foam::whaleBlendedDisplacementMotionSolver::mergedPatchDisplacement() const
{
    const pointPatchVectorField& ppf =
        pointDisplacement_.boundaryField()[patchi_];
    if (!isA<valuePointPatchField<vector>>(ppf))
    {
        FatalErrorInFunction
            << "pointDisplacement on patch " << ppf.patch().name() << " is "
            << ppf.type() << ": whaleBlendedDisplacement needs a"
            << " fixed-value kind of condition (e.g. stepServerDisplacement)"
            << exit(FatalError);
    }
    return patchPoints_->merge(refCast<const valuePointPatchField<vector>>(ppf)
    );
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::whaleBlendedDisplacementMotionSolver::
    whaleBlendedDisplacementMotionSolver(
        const polyMesh& mesh,
        const IOdictionary& dict
    ) :
    displacementMotionSolver(mesh, dict, typeName)
{
    readCoeffs();
    calcWeights();
    gamgRestartOrder::New(mesh);
}


Foam::whaleBlendedDisplacementMotionSolver::
    whaleBlendedDisplacementMotionSolver(
        const polyMesh& mesh,
        const IOdictionary& dict,
        const pointVectorField& pointDisplacement,
        const pointIOField& points0
    ) :
    displacementMotionSolver(mesh, dict, pointDisplacement, points0, typeName)
{
    readCoeffs();
    calcWeights();
    gamgRestartOrder::New(mesh);
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

Foam::tmp<Foam::pointField>
Foam::whaleBlendedDisplacementMotionSolver::curPoints() const
{
    tmp<pointField> tcurPoints(points0() + pointDisplacement_.primitiveField());
    twoDCorrectPoints(tcurPoints.ref());
    return tcurPoints;
}


void Foam::whaleBlendedDisplacementMotionSolver::solve()
{
    // The whale's condition asks the step-server (once per time)
    pointDisplacement_.boundaryFieldRef().updateCoeffs();

    const vectorField dPatch(mergedPatchDisplacement());
    // the sources' displacements: the patch points' own, or with clusters
    // theirs followed by the clusters'
    const tmp<vectorField> td(
        clusters_.valid() ? clusters_->sources(dPatch)
                          : tmp<vectorField>(dPatch)
    );
    const vectorField& d = td();
    vectorField& pd = pointDisplacement_.primitiveFieldRef();

    // Only the patch's own points and the blended ones move
    pd = Zero;

    if (rotation_)
    {
        const tensorField Rm(
            rotations_->rotations(patchPoints_->points(), dPatch)
        );
        weights_->apply(d, Rm, points0(), patchPoints_->points(), pd);
    }
    else
    {
        weights_->apply(d, pd);
    }

    // The patch itself (evaluate() of its condition, no new request), the
    // other patches' conditions (slip: projected), points on several
    // constrained patches
    pointConstraints::New(pointDisplacement_.mesh())
        .constrainDisplacement(pointDisplacement_, false);

    // The points the mesh is about to move to, checked first
    if (motionCheck_.valid())
    {
        motionCheck_->check(curPoints());
    }
}


void Foam::whaleBlendedDisplacementMotionSolver::updateMesh(const mapPolyMesh&)
{
    FatalErrorInFunction << typeName << " does not support topology changes"
                         << exit(FatalError);
}


// ************************************************************************* //
