/*---------------------------------------------------------------------------*\
    whale-adapter: a mesh's geometry at other points
    (see movedMeshGeometry.H)
\*---------------------------------------------------------------------------*/

#include "movedMeshGeometry.H"

// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

void Foam::movedMeshGeometry::makeFaces
(
    const primitiveMesh& mesh,
    const pointField& p
)
{
    const faceList& fs = mesh.faces();
    faceCentres_.setSize(fs.size());
    faceAreas_.setSize(fs.size());
    forAll(fs, facei)
    {
        const face& f = fs[facei];
        const label nPoints = f.size();
        if (nPoints == 3)
        {
            faceCentres_[facei] = (1.0/3.0)*(p[f[0]] + p[f[1]] + p[f[2]]);
            faceAreas_[facei] = 0.5*((p[f[1]] - p[f[0]])^(p[f[2]] - p[f[0]]));
            continue;
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
            const vector n = (nextPoint - thisPoint)^(fCentre - thisPoint);
            const scalar a = mag(n);
            sumN += n;
            sumA += a;
            sumAc += a*c;
        }
        // (a zero-area face keeps the points' mean and a zero area)
        const bool zero = sumA < ROOTVSMALL;
        faceCentres_[facei] = zero ? fCentre : (1.0/3.0)*sumAc/sumA;
        faceAreas_[facei] = zero ? vector(Zero) : 0.5*sumN;
    }
}


void Foam::movedMeshGeometry::makeCells(const primitiveMesh& mesh)
{
    const labelList& own = mesh.faceOwner();
    const labelList& nei = mesh.faceNeighbour();
    const vectorField& fc = faceCentres_;
    const vectorField& fa = faceAreas_;

    // The mean of the face centres first, then the face pyramids' volumes
    // and volume-weighted centres about it
    vectorField cEst(mesh.nCells(), Zero);
    labelField nCellFaces(mesh.nCells(), Zero);
    forAll(own, facei)
    {
        cEst[own[facei]] += fc[facei];
        ++nCellFaces[own[facei]];
    }
    forAll(nei, facei)
    {
        cEst[nei[facei]] += fc[facei];
        ++nCellFaces[nei[facei]];
    }
    forAll(cEst, celli)
    {
        cEst[celli] /= nCellFaces[celli];
    }

    cellCentres_ = vectorField(mesh.nCells(), Zero);
    cellVolumes_ = scalarField(mesh.nCells(), Zero);
    forAll(own, facei)
    {
        const label c = own[facei];
        const scalar pyr3Vol = fa[facei] & (fc[facei] - cEst[c]);
        cellCentres_[c] += pyr3Vol*((3.0/4.0)*fc[facei] + (1.0/4.0)*cEst[c]);
        cellVolumes_[c] += pyr3Vol;
    }
    forAll(nei, facei)
    {
        const label c = nei[facei];
        const scalar pyr3Vol = fa[facei] & (cEst[c] - fc[facei]);
        cellCentres_[c] += pyr3Vol*((3.0/4.0)*fc[facei] + (1.0/4.0)*cEst[c]);
        cellVolumes_[c] += pyr3Vol;
    }
    forAll(cellCentres_, celli)
    {
        cellCentres_[celli] =
            mag(cellVolumes_[celli]) > VSMALL
          ? cellCentres_[celli]/cellVolumes_[celli] : cEst[celli];
    }
    cellVolumes_ *= (1.0/3.0);
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::movedMeshGeometry::movedMeshGeometry
(
    const primitiveMesh& mesh,
    const pointField& p
)
{
    makeFaces(mesh, p);
    makeCells(mesh);
}


// ************************************************************************* //
