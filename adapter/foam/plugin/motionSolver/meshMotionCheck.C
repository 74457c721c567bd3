/*---------------------------------------------------------------------------*\
    whale-adapter: a mesh motion checked before the mesh moves
    (see meshMotionCheck.H)
\*---------------------------------------------------------------------------*/

#include "meshMotionCheck.H"
#include "movedMeshGeometry.H"
#include "movingMeshPart.H"
#include "primitiveMeshTools.H"
#include "polyMeshTools.H"
#include "syncTools.H"
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
        place = returnReduce(
            Pstream::myProcNo() == rank ? place : point(Zero),
            sumOp<point>()
        );
        worst = w;
    }
};


//- The volume of the pyramid of a face (centre fc, area vector fa) with
//  apex c, positive when c is on the side fa points away from (the owner's)
inline scalar pyramidVolume(const point& fc, const vector& fa, const point& c)
{
    return (1.0 / 3.0) * (fa & (fc - c));
}


//- The cosine of each face's non-orthogonality (1 on uncoupled boundary
//  faces): the faces listed, from the face areas and cell centres cc of
//  the whole mesh (polyMeshTools::faceOrthogonality; collective)
void faceOrthogonality(
    const polyMesh& mesh,
    const labelUList& faces,
    const vectorField& areas,
    const vectorField& cc,
    scalarField& ortho
)
{
    const labelList& own = mesh.faceOwner();
    const labelList& nei = mesh.faceNeighbour();
    const polyBoundaryMesh& pbm = mesh.boundaryMesh();
    pointField neiCc;
    syncTools::swapBoundaryCellPositions(mesh, cc, neiCc);
    for (const label facei : faces)
    {
        if (mesh.isInternalFace(facei))
        {
            ortho[facei] = primitiveMeshTools::faceOrthogonality(
                cc[own[facei]],
                cc[nei[facei]],
                areas[facei]
            );
        }
        else if (pbm[pbm.whichPatch(facei)].coupled())
        {
            ortho[facei] = primitiveMeshTools::faceOrthogonality(
                cc[own[facei]],
                neiCc[facei - mesh.nInternalFaces()],
                areas[facei]
            );
        }
        else
        {
            ortho[facei] = 1;
        }
    }
}


string plural(const label n, const char* one, const char* many)
{
    OStringStream os;
    os << n << ' ' << (n == 1 ? one : many);
    return os.str();
}

} // End anonymous namespace


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::meshMotionCheck::meshMotionCheck(
    const polyMesh& mesh,
    const word& owner
) :
    mesh_(mesh),
    owner_(owner),
    inUse_(mesh.time().value()),
    lastWritten_(inUse_),
    masterFaces_(syncTools::getInternalOrMasterFaces(mesh)),
    ortho_(polyMeshTools::faceOrthogonality(
        mesh,
        mesh.faceAreas(),
        mesh.cellCentres()
    ))
{}


// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

Foam::string Foam::meshMotionCheck::diagnose(
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
    const labelList& own = mesh_.faceOwner();
    const labelList& nei = mesh_.faceNeighbour();
    const vectorField& fCtrs = moved.faceCentres();
    forAll(fAreas, facei)
    {
        const point& fc = mesh_.faceCentres()[facei];
        const scalar ownPyr =
            pyramidVolume(fCtrs[facei], fAreas[facei], cellCtrs[own[facei]]);
        if (ownPyr < -SMALL)
        {
            pyr.note(ownPyr, fc);
        }
        if (mesh_.isInternalFace(facei))
        {
            const scalar neiPyr = -pyramidVolume(
                fCtrs[facei],
                fAreas[facei],
                cellCtrs[nei[facei]]
            );
            if (neiPyr < -SMALL)
            {
                pyr.note(neiPyr, fc);
            }
        }
    }
    // (cos of the angle; 90 degrees or more is an error whatever the
    // severe-non-orthogonality threshold)
    const scalarField ortho(
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
    const auto add = [&](const string& what,
                         const finding& f,
                         const scalar worst,
                         const char* how,
                         const char* centre)
    {
        brief << (brief.str().empty() ? "" : "; ") << what.c_str();
        os << "    " << what.c_str() << ": the worst " << worst << ' ' << how
           << ", " << centre << " centre at " << f.place << " m" << nl;
    };
    if (vol.n)
    {
        add("cell volumes: " + plural(vol.n, "cell", "cells")
                + " of zero or negative volume",
            vol,
            vol.worst,
            "m3",
            "cell");
    }
    if (area.n)
    {
        add("face areas: " + plural(area.n, "face", "faces") + " of zero area",
            area,
            area.worst,
            "m2",
            "face");
    }
    if (pyr.n)
    {
        add("face pyramids: " + plural(pyr.n, "face", "faces")
                + " incorrectly oriented",
            pyr,
            pyr.worst,
            "m3 (pyramid volume)",
            "face");
    }
    if (orth.n)
    {
        add("non-orthogonality: " + plural(orth.n, "face", "faces")
                + " at 90 deg or more",
            orth,
            radToDeg(::acos(min(1.0, max(-1.0, orth.worst)))),
            "deg",
            "face");
    }
    summary = brief.str();
    if (summary.empty())
    {
        summary = "polyMesh::checkMeshMotion failed";
    }
    os << "    (the places are centres in the mesh in use, of t = "
       << Time::timeName(inUse_) << " s)" << nl;
    return os.str();
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void Foam::meshMotionCheck::check(const pointField& newPoints)
{
    // The part that moves, its new geometry; the other cells' centres are
    // the mesh's
    const movingMeshPart part(mesh_, newPoints);
    const movedMeshGeometry moved(mesh_, newPoints, part.faces(), part.cells());
    vectorField cc(mesh_.cellCentres());
    for (const label celli : part.cells())
    {
        cc[celli] = moved.cellCentres()[celli];
    }
    const vectorField& fc = moved.faceCentres();
    const vectorField& fa = moved.faceAreas();
    faceOrthogonality(mesh_, part.faces(), fa, cc, ortho_);

    // checkMeshMotion's four checks (its limits) on the part
    label nBad = 0;
    for (const label celli : part.cells())
    {
        nBad += moved.cellVolumes()[celli] < VSMALL;
    }
    const labelList& own = mesh_.faceOwner();
    const labelList& nei = mesh_.faceNeighbour();
    for (const label facei : part.faces())
    {
        nBad += mag(fa[facei]) < VSMALL;
        nBad += pyramidVolume(fc[facei], fa[facei], cc[own[facei]]) < -SMALL;
        nBad += mesh_.isInternalFace(facei)
            && -pyramidVolume(fc[facei], fa[facei], cc[nei[facei]]) < -SMALL;
        nBad += ortho_[facei] <= SMALL;
    }
    const bool invalid = returnReduce(nBad, sumOp<label>()) > 0;

    const Time& runTime = mesh_.time();
    if (!invalid)
    {
        // The whole new mesh's figures, as OpenFOAM's checks print them
        scalar minVol = GREAT;
        scalar sumVol = 0;
        const scalarField& vols = mesh_.cellVolumes();
        forAll(vols, celli)
        {
            const scalar v =
                part.moves(celli) ? moved.cellVolumes()[celli] : vols[celli];
            minVol = min(minVol, v);
            sumVol += v;
        }
        scalar minDDotS = GREAT;
        scalar sumDDotS = 0;
        for (const label facei : masterFaces_)
        {
            minDDotS = min(minDDotS, ortho_[facei]);
            sumDDotS += ortho_[facei];
        }
        reduce(minVol, minOp<scalar>());
        reduce(sumVol, sumOp<scalar>());
        reduce(minDDotS, minOp<scalar>());
        reduce(sumDDotS, sumOp<scalar>());
        const label nSummed =
            returnReduce(label(masterFaces_.count()), sumOp<label>());
        const auto deg = [](const scalar c)
        {
            return radToDeg(::acos(min(1.0, max(-1.0, c))));
        };
        Info << owner_ << ": the new mesh: Min volume = " << minVol
             << ". Total volume = " << sumVol
             << ". Mesh non-orthogonality Max: " << deg(minDDotS)
             << " average: " << deg(sumDDotS / max(nSummed, label(1))) << " ("
             << returnReduce(part.cells().size(), sumOp<label>()) << " of "
             << returnReduce(mesh_.nCells(), sumOp<label>()) << " cells moved)"
             << endl;

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
        << "); stopped before moving it" << nl << details.c_str()
        << "The mesh of the latest written time, t = " << written
        << " s, is valid: every mesh this run moved to passed this check"
        << " (checkMesh -time " << written << ")." << nl
        << "What to do: make the patch's motion gentler there, or spread it"
        << " over more cells (larger innerDistance and outerDistance in "
        << owner_ << "Coeffs), or use a mesh whose cells there can follow"
        << " it; then run again from t = " << written << ". checkMotion"
        << " no turns this check off (the run then moves into the invalid"
        << " mesh)." << nl << exit(FatalError);
}


// ************************************************************************* //
