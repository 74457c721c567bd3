/*---------------------------------------------------------------------------*\
  =========                 |
  \\      /  F ield         | OpenFOAM: The Open Source CFD Toolbox
   \\    /   O peration     |
    \\  /    A nd           | www.openfoam.com
     \\/     M anipulation  |
-------------------------------------------------------------------------------
    Shape copied from OpenFOAM's functionObjects::forces,
    Copyright (C) 2011-2016 OpenFOAM Foundation,
    Copyright (C) 2015-2020 OpenCFD Ltd., GPL-3.0-or-later.
\*---------------------------------------------------------------------------*/

#include "whaleLoads.H"
#include "patchLoads.H"
#include "common/whaleFoamCompat.H"
#include "volFields.H"
#include "surfaceFields.H"
#include "addToRunTimeSelectionTable.H"
#include <algorithm>

// * * * * * * * * * * * * * * Static Data Members * * * * * * * * * * * * * //

namespace Foam
{
namespace functionObjects
{
defineTypeNameAndDebug(whaleLoads, 0);
addToRunTimeSelectionTable(functionObject, whaleLoads, dictionary);
}
}


namespace
{
// The columns of one group in loads.dat
const char* const columns[] = {
    "Fx",
    "Fy",
    "Fz",
    "Fpx",
    "Fpy",
    "Fpz",
    "Fvx",
    "Fvy",
    "Fvz",
    "P",
    "Pp",
    "Pv",
    "A"
};

// The layout of one group's values (class whaleLoadSums)
constexpr Foam::label FP = Foam::whaleLoadSums::FP;
constexpr Foam::label FV = Foam::whaleLoadSums::FV;
constexpr Foam::label PP = Foam::whaleLoadSums::PP;
constexpr Foam::label PV = Foam::whaleLoadSums::PV;
constexpr Foam::label AREA = Foam::whaleLoadSums::AREA;
}


// * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * * //

Foam::wordList Foam::functionObjects::whaleLoads::groupNames() const
{
    return whaleLoadSums::groupNames(
        mesh_.boundaryMesh(),
        patchIDs_,
        regionsPtr_.get()
    );
}


Foam::whaleLoadSums Foam::functionObjects::whaleLoads::calcLoads() const
{
    // Collective only with gradient whole (grad(U) across processor patches)
    const patchLoads loads(mesh_, rhoInf_, pName_, wholeMeshGradient_);
    const volVectorField* UPtr = mesh_.findObject<volVectorField>(UName_);

    if (!loads.hasPressure() || !UPtr)
    {
        FatalErrorInFunction << type() << " " << name() << ": no field "
                             << pName_ << " or " << UName_ << " in the database"
                             << exit(FatalError);
    }
    if (!loads.hasViscous())
    {
        FatalErrorInFunction
            << type() << " " << name() << ": no incompressible turbulence"
            << " model (laminar included) for the viscous force"
            << exit(FatalError);
    }

    return whaleLoadSums(loads, *UPtr, patchIDs_, regionsPtr_.get());
}


void Foam::functionObjects::whaleLoads::createFile()
{
    if (!writeToFile() || filePtr_.valid())
    {
        return;
    }

    filePtr_ = writeFile::whaleFileAtStartTime("loads");
    OFstream& os = filePtr_();

    writeHeader(os, "Loads on the whale patches (N, W, m2)");
    writeHeader(os, "F = Fp + Fv: force of the fluid on the patch");
    writeHeader(os, "P = Pp + Pv = -sum(F_f & U_f): power into the fluid");
    writeCommented(os, "Time");

    wordList groups(1, word("total"));
    groups.append(groupNames());
    for (const word& group : groups)
    {
        for (const char* col : columns)
        {
            writeTabbed(os, group + ":" + col);
        }
    }
    os << endl;
}


void Foam::functionObjects::whaleLoads::writeGroup(
    const word& group,
    const scalarField& v
)
{
    const vector Fp(whaleLoadSums::vectorAt(v, FP));
    const vector Fv(whaleLoadSums::vectorAt(v, FV));
    const vector F(Fp + Fv);
    const scalar P = v[PP] + v[PV];

    Log << type() << " " << name() << ": " << group << " F " << F
        << " N (pressure " << Fp << ", viscous " << Fv << "), P " << P
        << " W (pressure " << v[PP] << ", viscous " << v[PV] << "), A "
        << v[AREA] << " m2" << endl;

    if (filePtr_.valid())
    {
        OFstream& os = filePtr_();
        const scalar row[] = {
            F.x(),
            F.y(),
            F.z(),
            Fp.x(),
            Fp.y(),
            Fp.z(),
            Fv.x(),
            Fv.y(),
            Fv.z(),
            P,
            v[PP],
            v[PV],
            v[AREA]
        };
        for (const scalar x : row)
        {
            os << tab << x;
        }
    }
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::functionObjects::whaleLoads::whaleLoads(
    const word& name,
    const Time& runTime,
    const dictionary& dict
) :
    fvMeshFunctionObject(name, runTime, dict),
    writeFile(mesh_, name),
    patchIDs_(),
    rhoInf_(patchLoads::defaultRhoInf),
    pName_("p"),
    UName_("U"),
    wholeMeshGradient_(false),
    regionsFile_(),
    regionsPtr_(),
    filePtr_()
{
    read(dict);
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

bool Foam::functionObjects::whaleLoads::read(const dictionary& dict)
{
    fvMeshFunctionObject::read(dict);
    writeFile::read(dict);

    const wordRes patchNames(dict.get<wordRes>("patches"));
    patchIDs_ = mesh_.boundaryMesh().patchSet(patchNames).sortedToc();
    if (patchIDs_.empty())
    {
        FatalIOErrorInFunction(dict)
            << type() << " " << name() << ": patches " << patchNames
            << " select no patch; the patches are "
            << mesh_.boundaryMesh().names() << exit(FatalIOError);
    }

    rhoInf_ = dict.getOrDefault<scalar>("rhoInf", patchLoads::defaultRhoInf);
    if (!(rhoInf_ > 0))
    {
        FatalIOErrorInFunction(dict)
            << type() << " " << name() << ": rhoInf " << rhoInf_
            << " must be > 0 (kg/m3)" << exit(FatalIOError);
    }
    pName_ = dict.getOrDefault<word>("p", "p");
    UName_ = dict.getOrDefault<word>("U", "U");
    const word gradient(dict.getOrDefault<word>("gradient", "cells"));
    if (gradient != "cells" && gradient != "whole")
    {
        FatalIOErrorInFunction(dict)
            << type() << " " << name() << ": gradient " << gradient
            << " is not cells (the default) or whole" << exit(FatalIOError);
    }
    wholeMeshGradient_ = (gradient == "whole");

    // The faces' regions are (re)made at the next execution
    regionsFile_.clear();
    regionsPtr_.clear();
    if (dict.readIfPresent("regions", regionsFile_))
    {
        regionsFile_.expand();
    }

    Info << type() << " " << name() << ": patches";
    for (const label patchi : patchIDs_)
    {
        Info << " " << mesh_.boundaryMesh()[patchi].name();
    }
    Info << ", rhoInf " << rhoInf_ << ", grad(U) of the "
         << (wholeMeshGradient_ ? "whole mesh" : "patch cells");
    if (!regionsFile_.empty())
    {
        Info << ", regions from " << regionsFile_;
    }
    Info << endl;

    return true;
}


bool Foam::functionObjects::whaleLoads::execute()
{
    if (!regionsFile_.empty() && !regionsPtr_.valid())
    {
        regionsPtr_.reset(new whaleRegions(regionsFile_, mesh_, patchIDs_));
        Info << type() << " " << name() << ": regions";
        forAll(regionsPtr_->names(), r)
        {
            label n = 0;
            forAll(patchIDs_, i)
            {
                const labelList& l = regionsPtr_->faceRegions(i);
                n += label(std::count(l.begin(), l.end(), r));
            }
            Info << " " << regionsPtr_->names()[r] << " ("
                 << returnReduce(n, sumOp<label>()) << " faces)";
        }
        Info << ", face centres at most " << regionsPtr_->maxDistance()
             << " m from " << regionsFile_ << endl;
    }

    const whaleLoadSums sums(calcLoads());
    const List<scalarField>& values = sums.groups();
    const scalarField& total = sums.total();
    const wordList groups(groupNames());

    if (Pstream::master())
    {
        createFile();
        if (filePtr_.valid())
        {
            writeCurrentTime(filePtr_());
        }
    }

    writeGroup("total", total);
    forAll(groups, i)
    {
        writeGroup(groups[i], values[i]);
    }

    if (filePtr_.valid())
    {
        filePtr_() << endl;
    }

    setResult("power", total[PP] + total[PV]);
    setResult(
        "force",
        whaleLoadSums::vectorAt(total, FP) + whaleLoadSums::vectorAt(total, FV)
    );

    return true;
}


bool Foam::functionObjects::whaleLoads::write()
{
    return true;
}


// ************************************************************************* //
