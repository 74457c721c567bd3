/*---------------------------------------------------------------------------*\
    whale-adapter: a mesh's geometry at other points
    (see movedMeshGeometry.H)
\*---------------------------------------------------------------------------*/

#include "movedMeshGeometry.H"
#include "ListOps.H"

// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

void Foam::movedMeshGeometry::makeFace(
    const face& f,
    const pointField& p,
    const label facei
)
{
    const label nPoints = f.size();
    if (nPoints == 3)
    {
        faceCentres_[facei] = (1.0 / 3.0) * (p[f[0]] + p[f[1]] + p[f[2]]);
        faceAreas_[facei] = 0.5 * ((p[f[1]] - p[f[0]]) ^ (p[f[2]] - p[f[0]]));
        return;
    }
    vector sumN = Zero;
    scalar sumA = 0;
    vector sumAc = Zero;
    vector fCentre = p[f[0]];
    for (label pi = 1; pi < nPoints; pi++)
    {
        fCentre += p[f[pi]];
    }
    fCentre /= nPoints;
    for (label pi = 0; pi < nPoints; pi++)
    {
        const point& thisPoint = p[f[pi]];
        const point& nextPoint = p[f[pi == nPoints - 1 ? 0 : pi + 1]];
        const vector c = thisPoint + nextPoint + fCentre;
        const vector n = (nextPoint - thisPoint) ^ (fCentre - thisPoint);
        const scalar a = mag(n);
        sumN += n;
        sumA += a;
        sumAc += a * c;
    }
    // (a zero-area face keeps the points' mean and a zero area)
    const bool zero = sumA < ROOTVSMALL;
    faceCentres_[facei] = zero ? fCentre : (1.0 / 3.0) * sumAc / sumA;
    faceAreas_[facei] = zero ? vector(Zero) : 0.5 * sumN;
}


void Foam::movedMeshGeometry::makeCell(
    const primitiveMesh& mesh,
    const label celli
)
{
    const labelList& own = mesh.faceOwner();
    const cell& cFaces = mesh.cells()[celli];
    const vectorField& fc = faceCentres_;
    const vectorField& fa = faceAreas_;

    // The mean of the face centres first, then the face pyramids' volumes
    // and volume-weighted centres about it
    vector cEst = Zero;
    for (const label facei : cFaces)
    {
        cEst += fc[facei];
    }
    cEst /= cFaces.size();

    vector cc = Zero;
    scalar vol = 0;
    for (const label facei : cFaces)
    {
        const scalar pyr3Vol = own[facei] == celli
            ? fa[facei] & (fc[facei] - cEst)
            : fa[facei] & (cEst - fc[facei]);
        cc += pyr3Vol * ((3.0 / 4.0) * fc[facei] + (1.0 / 4.0) * cEst);
        vol += pyr3Vol;
    }
    cellCentres_[celli] = mag(vol) > VSMALL ? cc / vol : cEst;
    cellVolumes_[celli] = vol * (1.0 / 3.0);
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::movedMeshGeometry::movedMeshGeometry(
    const primitiveMesh& mesh,
    const pointField& p
) :
    movedMeshGeometry(mesh, p, identity(mesh.nFaces()), identity(mesh.nCells()))
{}


Foam::movedMeshGeometry::movedMeshGeometry(
    const primitiveMesh& mesh,
    const pointField& p,
    const labelUList& faces,
    const labelUList& cells
) :
    faceCentres_(mesh.nFaces()),
    faceAreas_(mesh.nFaces()),
    cellCentres_(mesh.nCells()),
    cellVolumes_(mesh.nCells())
{
    const faceList& fs = mesh.faces();
    for (const label facei : faces)
    {
        makeFace(fs[facei], p, facei);
    }
    for (const label celli : cells)
    {
        makeCell(mesh, celli);
    }
}


// ************************************************************************* //
