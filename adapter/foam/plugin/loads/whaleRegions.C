/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | OpenFOAM: The Open Source CFD Toolbox
   \\    /   O peration     |
    \\  /    A nd           | www.openfoam.com
     \\/     M anipulation  |
-------------------------------------------------------------------------------
    Part of whale-adapter's plugin library (GPL-3.0-or-later, as OpenFOAM).
\*---------------------------------------------------------------------------*/

#include "whaleRegions.H"
#include "triSurface.H"
#include "triSurfaceSearch.H"
#include "points0MotionSolver.H"
#include "pointIOField.H"
#include "boundBox.H"

// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::whaleRegions::whaleRegions(
    const fileName& surfaceFile,
    const polyMesh& mesh,
    const labelList& patchIDs
) :
    names_(),
    faceRegions_(patchIDs.size()),
    maxDistance_(0)
{
    // Every rank reads the (small) file
    const triSurface surf(surfaceFile);
    if (surf.empty())
    {
        FatalErrorInFunction << "the region surface " << surfaceFile
                             << " has no triangles" << exit(FatalError);
    }

    // The solids' names (a binary STL has none: region0, region1, ...)
    label nRegions = surf.patches().size();
    for (const labelledTri& f : surf)
    {
        nRegions = max(nRegions, f.region() + 1);
    }
    names_.setSize(nRegions);
    forAll(names_, regioni)
    {
        if (regioni < surf.patches().size())
        {
            names_[regioni] = surf.patches()[regioni].name();
        }
        if (names_[regioni].empty())
        {
            names_[regioni] = "region" + Foam::name(regioni);
        }
    }

    // The undeformed points: what the displacement motion solver starts from
    pointField points0(mesh.points());
    {
        IOobject io(points0MotionSolver::points0IO(mesh));
        if (io.typeHeaderOk<pointIOField>())
        {
            const pointIOField read(io);
            if (read.size() == mesh.nPoints())
            {
                points0 = read;
            }
        }
    }

    const triSurfaceSearch search(surf);
    const boundBox surfBox(surf.points(), false);
    const boundBox meshBox(points0, false);
    const scalar span = surfBox.mag() + meshBox.mag() + VSMALL;

    forAll(patchIDs, i)
    {
        const polyPatch& pp = mesh.boundaryMesh()[patchIDs[i]];

        pointField centres(pp.size());
        forAll(pp, facei)
        {
            centres[facei] = pp[facei].centre(points0);
        }

        List<pointIndexHit> hits;
        search.findNearest(centres, scalarField(pp.size(), sqr(span)), hits);

        labelList& regions = faceRegions_[i];
        regions.setSize(pp.size());
        forAll(hits, facei)
        {
            if (!hits[facei].hit())
            {
                FatalErrorInFunction << "no triangle of " << surfaceFile
                                     << " near face " << facei << " of patch "
                                     << pp.name() << " at " << centres[facei]
                                     << exit(FatalError);
            }
            regions[facei] = surf[hits[facei].index()].region();
            maxDistance_ =
                max(maxDistance_, mag(hits[facei].hitPoint() - centres[facei]));
        }
    }

    reduce(maxDistance_, maxOp<scalar>());
}


// ************************************************************************* //
