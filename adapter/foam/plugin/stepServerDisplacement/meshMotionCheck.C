/*---------------------------------------------------------------------------*\
    whale-adapter: a mesh motion checked before the mesh moves
    (see meshMotionCheck.H)
\*---------------------------------------------------------------------------*/

#include "meshMotionCheck.H"
#include "movedMeshGeometry.H"
#include "primitiveMeshTools.H"
#include "polyMeshTools.H"
#include "unitConversion.H"
#include "OStringStream.H"
#include "Time.H"

namespace
{

using namespace Foam;

//- What one check found on this rank: how many, the worst (smallest)
//  value and the place that goes with it
struct finding
{
    label n = 0;
    scalar worst = GREAT;
    point place = Zero;

    void note(const scalar value, const point& where)
    {
        ++n;
        if (value < worst)
        {
            worst = value;
            place = where;
        }
    }

    //- Over the ranks (collective): the total count and, when not zero,
    //  the worst value of all ranks and its place (the lowest rank's if
    //  tied)
    void reduceOverRanks()
    {
        const bool mine = n > 0;
        reduce(n, sumOp<label>());
        if (!n)
        {
            return;
        }
        const scalar w = returnReduce(mine ? worst : GREAT, minOp<scalar>());
        label rank =
            mine && worst == w ? Pstream::myProcNo() : Pstream::nProcs();
        reduce(rank, minOp<label>());
        place = returnReduce
        (
            Pstream::myProcNo() == rank ? place : point(Zero),
            sumOp<point>()
        );
        worst = w;
    }
};


string plural(const label n, const char* one, const char* many)
{
    OStringStream os;
    os << n << ' ' << (n == 1 ? one : many);
    return os.str();
}

} // End anonymous namespace


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::meshMotionCheck::meshMotionCheck(const polyMesh& mesh, const word& owner)
:
    mesh_(mesh),
    owner_(owner),
    inUse_(mesh.time().value()),
    lastWritten_(inUse_)
{}


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

Foam::string Foam::meshMotionCheck::diagnose
(
    const pointField& newPoints,
    string& summary
) const
{
    const movedMeshGeometry moved(mesh_, newPoints);
    const scalarField& cellVols = moved.cellVolumes();
    const vectorField& fAreas = moved.faceAreas();
    const vectorField& cellCtrs = moved.cellCentres();

    // The four checks of polyMesh::checkMeshMotion, with its limits; the
    // places are centres in the mesh in use (the previous step's)
    finding vol, area, pyr, orth;
    forAll(cellVols, celli)
    {
        if (cellVols[celli] < VSMALL)
        {
            vol.note(cellVols[celli], mesh_.cellCentres()[celli]);
        }
    }
    forAll(fAreas, facei)
    {
        if (mag(fAreas[facei]) < VSMALL)
        {
            area.note(mag(fAreas[facei]), mesh_.faceCentres()[facei]);
        }
    }
    scalarField ownPyr, neiPyr;
    primitiveMeshTools::facePyramidVolume
    (
        mesh_, newPoints, cellCtrs, ownPyr, neiPyr
    );
    forAll(ownPyr, facei)
    {
        const point& fc = mesh_.faceCentres()[facei];
        if (ownPyr[facei] < -SMALL)
        {
            pyr.note(ownPyr[facei], fc);
        }
        if (mesh_.isInternalFace(facei) && neiPyr[facei] < -SMALL)
        {
            pyr.note(neiPyr[facei], fc);
        }
    }
    // (cos of the angle; 90 degrees or more is an error whatever the
    // severe-non-orthogonality threshold)
    const scalarField ortho
    (
        polyMeshTools::faceOrthogonality(mesh_, fAreas, cellCtrs)
    );
    forAll(ortho, facei)
    {
        if (ortho[facei] <= SMALL)
        {
            orth.note(ortho[facei], mesh_.faceCentres()[facei]);
        }
    }
    vol.reduceOverRanks();
    area.reduceOverRanks();
    pyr.reduceOverRanks();
    orth.reduceOverRanks();

    OStringStream brief, os;
    os.precision(6);
    const auto add = [&](const string& what, const finding& f, const scalar worst,
                         const char* how, const char* centre)
    {
        brief << (brief.str().empty() ? "" : "; ") << what.c_str();
        os  << "    " << what.c_str() << ": the worst " << worst << ' ' << how
            << ", " << centre << " centre at " << f.place << " m" << nl;
    };
    if (vol.n)
    {
        add("cell volumes: " + plural(vol.n, "cell", "cells")
          + " of zero or negative volume", vol, vol.worst, "m3", "cell");
    }
    if (area.n)
    {
        add("face areas: " + plural(area.n, "face", "faces") + " of zero area",
            area, area.worst, "m2", "face");
    }
    if (pyr.n)
    {
        add("face pyramids: " + plural(pyr.n, "face", "faces")
          + " incorrectly oriented", pyr, pyr.worst, "m3 (pyramid volume)",
            "face");
    }
    if (orth.n)
    {
        add("non-orthogonality: " + plural(orth.n, "face", "faces")
          + " at 90 deg or more", orth,
            radToDeg(::acos(min(1.0, max(-1.0, orth.worst)))), "deg", "face");
    }
    summary = brief.str();
    if (summary.empty())
    {
        summary = "polyMesh::checkMeshMotion failed";
    }
    os  << "    (the places are centres in the mesh in use, of t = "
        << Time::timeName(inUse_) << " s)" << nl;
    return os.str();
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void Foam::meshMotionCheck::check(const pointField& newPoints)
{
    // Quiet: with polyMesh's debug switch on (run-case's mesh watch) it
    // would print its lines now and again when the mesh moves
    const int debug0 = polyMesh::debug;
    polyMesh::debug = 0;
    const bool invalid = mesh_.checkMeshMotion(newPoints, false, false);
    polyMesh::debug = debug0;

    const Time& runTime = mesh_.time();
    if (!invalid)
    {
        inUse_ = runTime.value();
        if (runTime.writeTime())
        {
            lastWritten_ = inUse_;
        }
        return;
    }

    string summary;
    const string details(diagnose(newPoints, summary));
    const word written(Time::timeName(lastWritten_));
    FatalErrorInFunction
        << owner_ << ": the mesh at t = " << runTime.timeName()
        << " s would be invalid (" << summary.c_str()
        << "); stopped before moving it" << nl
        << details.c_str()
        << "The mesh of the latest written time, t = " << written
        << " s, is valid: every mesh this run moved to passed this check"
        << " (checkMesh -time " << written << ")." << nl
        << "What to do: make the patch's motion gentler there, or spread it"
        << " over more cells (larger innerDistance and outerDistance in "
        << owner_ << "Coeffs), or use a mesh whose cells there can follow"
        << " it; then run again from t = " << written << ". checkMotion"
        << " no turns this check off (the run then moves into the invalid"
        << " mesh)." << nl
        << exit(FatalError);
}


// ************************************************************************* //
