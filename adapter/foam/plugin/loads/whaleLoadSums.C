/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | OpenFOAM: The Open Source CFD Toolbox
   \\    /   O peration     |
    \\  /    A nd           | www.openfoam.com
     \\/     M anipulation  |
-------------------------------------------------------------------------------
    Part of whale-adapter's plugin library (GPL-3.0-or-later, as OpenFOAM).
\*---------------------------------------------------------------------------*/

#include "whaleLoadSums.H"
#include "patchLoads.H"
#include "whaleRegions.H"
#include "surfaceFields.H"

// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::whaleLoadSums::whaleLoadSums(
    const patchLoads& loads,
    const volVectorField& U,
    const labelList& patchIDs,
    const whaleRegions* regions
) :
    groups_(),
    total_(NVALUES, Zero)
{
    const fvMesh& mesh = U.mesh();
    const label nPatches = patchIDs.size();
    const label nR = regions ? regions->names().size() : 0;
    List<scalarField> values(nPatches * (1 + nR), scalarField(NVALUES, Zero));

    forAll(patchIDs, i)
    {
        const label patchi = patchIDs[i];
        const vectorField fp(loads.pressure(patchi));
        const vectorField fv(loads.viscous(patchi));
        const vectorField& Ub = U.boundaryField()[patchi];
        const scalarField& magSf = mesh.magSf().boundaryField()[patchi];

        const vector Fp(sum(fp));
        const vector Fv(sum(fv));
        scalarField& v = values[i];
        for (direction d = 0; d < vector::nComponents; ++d)
        {
            v[FP + d] = Fp[d];
            v[FV + d] = Fv[d];
        }

        // Face-wise: the fluid's force on the face times the face velocity,
        // negated: the power the body delivers to the fluid
        v[PP] = -sum(fp & Ub);
        v[PV] = -sum(fv & Ub);
        v[AREA] = sum(magSf);

        // The same sums over the faces of each region
        if (nR)
        {
            const labelList& faceRegions = regions->faceRegions(i);
            forAll(faceRegions, facei)
            {
                scalarField& w = values[nPatches + i * nR + faceRegions[facei]];
                for (direction d = 0; d < vector::nComponents; ++d)
                {
                    w[FP + d] += fp[facei][d];
                    w[FV + d] += fv[facei][d];
                }
                w[PP] -= fp[facei] & Ub[facei];
                w[PV] -= fv[facei] & Ub[facei];
                w[AREA] += magSf[facei];
            }
        }
    }

    Pstream::listCombineGather(values, plusEqOp<scalarField>());
    Pstream::listCombineScatter(values);

    groups_.transfer(values);
    forAll(patchIDs, i)
    {
        total_ += groups_[i];
    }
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

Foam::wordList Foam::whaleLoadSums::groupNames(
    const polyBoundaryMesh& boundary,
    const labelList& patchIDs,
    const whaleRegions* regions
)
{
    const label nR = regions ? regions->names().size() : 0;
    wordList groups;
    for (const label patchi : patchIDs)
    {
        groups.append(boundary[patchi].name());
    }
    for (const label patchi : patchIDs)
    {
        for (label r = 0; r < nR; ++r)
        {
            groups.append(boundary[patchi].name() + "." + regions->names()[r]);
        }
    }
    return groups;
}


// ************************************************************************* //
