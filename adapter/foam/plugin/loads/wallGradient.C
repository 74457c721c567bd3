/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | OpenFOAM: The Open Source CFD Toolbox
   \\    /   O peration     |
    \\  /    A nd           | www.openfoam.com
     \\/     M anipulation  |
-------------------------------------------------------------------------------
    Formulas of OpenFOAM v1912's gaussGrad, cellLimitedGrad (minmod),
    surfaceInterpolationScheme and linear, Copyright (C) 2011-2018 OpenFOAM
    Foundation, Copyright (C) 2019 OpenCFD Ltd., GPL-3.0-or-later.
\*---------------------------------------------------------------------------*/

#include "wallGradient.H"
#include "surfaceFields.H"

// * * * * * * * * * * * * * * * Local Functions * * * * * * * * * * * * * * //

namespace
{

// cellLimitedGrad::limitFaceCmpt with the minmod limiter min(r, 1)
void limitFaceCmpt(
    Foam::scalar& limiter,
    const Foam::scalar maxDelta,
    const Foam::scalar minDelta,
    const Foam::scalar extrapolate
)
{
    using namespace Foam;
    scalar r = 1;
    if (extrapolate > SMALL)
    {
        r = maxDelta / extrapolate;
    }
    else if (extrapolate < -SMALL)
    {
        r = minDelta / extrapolate;
    }
    else
    {
        return;
    }
    limiter = min(limiter, min(r, scalar(1)));
}


// cellLimitedGrad::limitFace for a vector field: component by component
void limitFace(
    Foam::vector& limiter,
    const Foam::vector& maxDelta,
    const Foam::vector& minDelta,
    const Foam::vector& extrapolate
)
{
    for (Foam::direction d = 0; d < Foam::vector::nComponents; ++d)
    {
        limitFaceCmpt(limiter[d], maxDelta[d], minDelta[d], extrapolate[d]);
    }
}

} // End anonymous namespace


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::wallGradient::wallGradient(const volVectorField& U) :
    mesh_(U.mesh()),
    U_(U),
    limited_(limitedScheme(U.mesh(), "grad(" + U.name() + ')')),
    neighbours_(U.boundaryField().size())
{
    forAll(U_.boundaryField(), patchi)
    {
        if (U_.boundaryField()[patchi].coupled())
        {
            neighbours_[patchi] =
                U_.boundaryField()[patchi].patchNeighbourField();
        }
    }
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

bool Foam::wallGradient::limitedScheme(const fvMesh& mesh, const word& name)
{
    const ITstream& is = mesh.gradScheme(name);
    const tokenList& t = is;
    auto isWord = [&t](const label i, const char* w)
    {
        return t[i].isWord() && t[i].wordToken() == w;
    };

    if (t.size() == 2 && isWord(0, "Gauss") && isWord(1, "linear"))
    {
        return false;
    }
    if (t.size() == 4 && isWord(0, "cellLimited") && isWord(1, "Gauss")
        && isWord(2, "linear") && t[3].isNumber() && t[3].number() == 1)
    {
        return true;
    }

    FatalErrorInFunction
        << "the wall-cell gradient of the forces reproduces the gradSchemes "
        << name << " 'cellLimited Gauss linear 1' and 'Gauss linear' only,"
        << " not '" << is.toString().c_str() << "': set one of them in"
        << " system/fvSchemes" << exit(FatalError);
    return false;
}


Foam::vector Foam::wallGradient::faceValue(
    const label patchi,
    const label i,
    const label celli
) const
{
    const fvPatchVectorField& Up = U_.boundaryField()[patchi];
    if (!Up.coupled())
    {
        return Up[i];
    }
    // surfaceInterpolationScheme::dotInterpolate across a coupled patch
    const scalar lambda = mesh_.weights().boundaryField()[patchi][i];
    return lambda * U_[celli] + (1.0 - lambda) * neighbours_[patchi][i];
}


const Foam::vector&
Foam::wallGradient::acrossValue(const label patchi, const label i) const
{
    const fvPatchVectorField& Up = U_.boundaryField()[patchi];
    return Up.coupled() ? neighbours_[patchi][i] : Up[i];
}


Foam::tensor Foam::wallGradient::gaussGradient(
    const label celli,
    const labelList& faces
) const
{
    const label nInternal = mesh_.nInternalFaces();
    const labelUList& owner = mesh_.owner();
    const labelUList& neighbour = mesh_.neighbour();
    const surfaceVectorField& Sf = mesh_.Sf();
    const scalarField& lambda = mesh_.weights();
    const polyBoundaryMesh& pbm = mesh_.boundaryMesh();

    tensor g(Zero);
    for (const label facei : faces)
    {
        if (facei < nInternal)
        {
            const label own = owner[facei];
            const label nei = neighbour[facei];
            const vector Uf(lambda[facei] * (U_[own] - U_[nei]) + U_[nei]);
            const tensor SfUf(Sf[facei] * Uf);
            if (own == celli)
            {
                g += SfUf;
            }
            else
            {
                g -= SfUf;
            }
            continue;
        }
        const label patchi = pbm.whichPatch(facei);
        const label i = facei - pbm[patchi].start();
        const vectorField& pSf = Sf.boundaryField()[patchi];
        if (i < pSf.size()) // an empty patch's fields have no faces
        {
            g += pSf[i] * faceValue(patchi, i, celli);
        }
    }
    g /= mesh_.V()[celli];
    return g;
}


void Foam::wallGradient::limit(
    const label celli,
    const labelList& faces,
    tensor& g
) const
{
    const label nInternal = mesh_.nInternalFaces();
    const labelUList& owner = mesh_.owner();
    const labelUList& neighbour = mesh_.neighbour();
    const polyBoundaryMesh& pbm = mesh_.boundaryMesh();
    const surfaceVectorField& Cf = mesh_.Cf();
    const vector& C = mesh_.C()[celli];

    // The extremes over the cell and its neighbours, less the cell's value
    vector maxU(U_[celli]);
    vector minU(U_[celli]);
    for (const label facei : faces)
    {
        if (facei < nInternal)
        {
            const label other =
                (owner[facei] == celli) ? neighbour[facei] : owner[facei];
            maxU = max(maxU, U_[other]);
            minU = min(minU, U_[other]);
            continue;
        }
        const label patchi = pbm.whichPatch(facei);
        const label i = facei - pbm[patchi].start();
        if (i < U_.boundaryField()[patchi].size())
        {
            maxU = max(maxU, acrossValue(patchi, i));
            minU = min(minU, acrossValue(patchi, i));
        }
    }
    maxU -= U_[celli];
    minU -= U_[celli];

    vector limiter(pTraits<vector>::one);
    for (const label facei : faces)
    {
        if (facei < nInternal)
        {
            limitFace(limiter, maxU, minU, (Cf[facei] - C) & g);
            continue;
        }
        const label patchi = pbm.whichPatch(facei);
        const label i = facei - pbm[patchi].start();
        const vectorField& pCf = Cf.boundaryField()[patchi];
        if (i < pCf.size())
        {
            limitFace(limiter, maxU, minU, (pCf[i] - C) & g);
        }
    }

    // cellLimitedGrad::limitGradient: column d of g (the derivatives of
    // U's component d) times the limiter of component d
    g = tensor(
        cmptMultiply(limiter, g.x()),
        cmptMultiply(limiter, g.y()),
        cmptMultiply(limiter, g.z())
    );
}


Foam::tensor Foam::wallGradient::cellGradient(const label celli) const
{
    // The cell's faces in ascending order: gaussGrad's and cellLimitedGrad's
    // loops run over the internal faces, then the patches in order
    labelList faces(mesh_.cells()[celli]);
    Foam::sort(faces);

    tensor g(gaussGradient(celli, faces));
    if (limited_)
    {
        limit(celli, faces, g);
    }
    return g;
}


Foam::tmp<Foam::tensorField> Foam::wallGradient::patchGradient(
    const label patchi
) const
{
    const labelUList& faceCells = mesh_.boundary()[patchi].faceCells();
    const vectorField& pSf = mesh_.Sf().boundaryField()[patchi];
    const scalarField& pMagSf = mesh_.magSf().boundaryField()[patchi];
    const vectorField snGrad(U_.boundaryField()[patchi].snGrad());

    tmp<tensorField> tgrad(new tensorField(faceCells.size()));
    tensorField& grad = tgrad.ref();
    forAll(faceCells, i)
    {
        // gaussGrad::correctBoundaryConditions on the cell's value
        const tensor g(cellGradient(faceCells[i]));
        const vector n(pSf[i] / pMagSf[i]);
        grad[i] = g;
        grad[i] += n * (snGrad[i] - (n & g));
    }
    return tgrad;
}


// ************************************************************************* //
