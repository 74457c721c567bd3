/*---------------------------------------------------------------------------*\
    whale-adapter: the part of a mesh that a motion changes
    (see movingMeshPart.H)
\*---------------------------------------------------------------------------*/

#include "movingMeshPart.H"
#include "syncTools.H"

// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::movingMeshPart::movingMeshPart(
    const polyMesh& mesh,
    const pointField& newPoints
) :
    moves_(mesh.nCells(), false)
{
    const pointField& points = mesh.points();
    const labelListList& pointCells = mesh.pointCells();
    forAll(points, pointi)
    {
        if (newPoints[pointi] != points[pointi])
        {
            for (const label celli : pointCells[pointi])
            {
                moves_[celli] = true;
            }
        }
    }

    boolList faceIn(mesh.nFaces(), false);
    const cellList& cells = mesh.cells();
    label nCells = 0;
    forAll(moves_, celli)
    {
        if (moves_[celli])
        {
            ++nCells;
            for (const label facei : cells[celli])
            {
                faceIn[facei] = true;
            }
        }
    }

    // Coupled faces whose cell on the other side moves
    const label nInternal = mesh.nInternalFaces();
    labelList ownMoves(mesh.nBoundaryFaces());
    forAll(ownMoves, bFacei)
    {
        ownMoves[bFacei] = moves_[mesh.faceOwner()[nInternal + bFacei]];
    }
    labelList neiMoves(ownMoves);
    syncTools::swapBoundaryFaceList(mesh, neiMoves);
    for (const polyPatch& pp : mesh.boundaryMesh())
    {
        if (pp.coupled())
        {
            forAll(pp, i)
            {
                const label facei = pp.start() + i;
                faceIn[facei] = faceIn[facei] || neiMoves[facei - nInternal];
            }
        }
    }

    cells_.setSize(nCells);
    nCells = 0;
    forAll(moves_, celli)
    {
        if (moves_[celli])
        {
            cells_[nCells++] = celli;
        }
    }
    label nFaces = 0;
    forAll(faceIn, facei)
    {
        nFaces += faceIn[facei];
    }
    faces_.setSize(nFaces);
    nFaces = 0;
    forAll(faceIn, facei)
    {
        if (faceIn[facei])
        {
            faces_[nFaces++] = facei;
        }
    }
}


// ************************************************************************* //
