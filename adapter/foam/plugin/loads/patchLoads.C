/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | OpenFOAM: The Open Source CFD Toolbox
   \\    /   O peration     |
    \\  /    A nd           | www.openfoam.com
     \\/     M anipulation  |
-------------------------------------------------------------------------------
    Formula as in OpenFOAM's functionObjects::forces (forces.C),
    Copyright (C) 2011-2016 OpenFOAM Foundation,
    Copyright (C) 2015-2020 OpenCFD Ltd., GPL-3.0-or-later.
\*---------------------------------------------------------------------------*/

#include "patchLoads.H"
#include "fvcGrad.H"

// * * * * * * * * * * * * * * * Static Data Members * * * * * * * * * * * * //

const Foam::scalar Foam::patchLoads::defaultRhoInf = 1025;

// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::patchLoads::patchLoads(
    const fvMesh& mesh,
    const scalar rhoInf,
    const word& pName,
    const bool wholeMesh
) :
    mesh_(mesh),
    rhoInf_(rhoInf),
    pPtr_(mesh.findObject<volScalarField>(pName)),
    turbPtr_(mesh.findObject<incompressible::turbulenceModel>(
        incompressible::turbulenceModel::propertiesName
    )),
    wallGradPtr_(),
    tgradU_()
{
    if (turbPtr_ && wholeMesh)
    {
        tgradU_ = fvc::grad(turbPtr_->U());
    }
    else if (turbPtr_)
    {
        wallGradPtr_.reset(new wallGradient(turbPtr_->U()));
    }
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

Foam::tmp<Foam::vectorField> Foam::patchLoads::pressure(const label patchi
) const
{
    const volScalarField& p = *pPtr_;

    // As forces::rho(p): p in Pa needs no density
    const scalar rho = (p.dimensions() == dimPressure) ? 1 : rhoInf_;

    return rho * mesh_.Sf().boundaryField()[patchi] * p.boundaryField()[patchi];
}


Foam::tmp<Foam::vectorField> Foam::patchLoads::viscous(const label patchi) const
{
    const tmp<tensorField> tgradUp(
        wallGradPtr_.valid()
            ? wallGradPtr_->patchGradient(patchi)
            : tmp<tensorField>(tgradU_().boundaryField()[patchi])
    );

    // devReff's value on the patch, the same operations in the same order:
    // (-nuEff)*dev(twoSymm(grad(U)))
    const symmTensorField devReff(
        (-turbPtr_->nuEff(patchi)) * dev(twoSymm(tgradUp()))
    );
    return rhoInf_ * (mesh_.Sf().boundaryField()[patchi] & devReff);
}


Foam::tmp<Foam::vectorField>
Foam::patchLoads::moments(const label patchi, const vectorField& f) const
{
    return mesh_.C().boundaryField()[patchi] ^ f;
}


// ************************************************************************* //
