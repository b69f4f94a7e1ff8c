//! Every FMU this one binary serves, estimators and plants: `fmi2Instantiate`
//! finds the one whose GUID it is given here, and `package-fmus` packages each.

use crate::estimators::{self, DefaultExperiment, Descriptor};
use crate::model_description::{documentation, plant_documentation};
use crate::plants::{self, PlantDescriptor};
use crate::variables::{EnumerationType, Kind, Variable};

/// What the shell, `modelDescription.xml` and the documentation need of any FMU.
pub trait FmuDescription {
    /// `modelIdentifier`.
    fn model_identifier(&self) -> &'static str;
    /// `modelName`.
    fn model_name(&self) -> &'static str;
    /// `description`.
    fn description(&self) -> &'static str;
    /// The variables; value reference = position.
    fn variables(&self) -> &[Variable];
    /// `<DefaultExperiment>`.
    fn default_experiment(&self) -> DefaultExperiment;
    /// The GUID.
    fn guid(&self) -> &str;
    /// `documentation/index.html`.
    fn documentation_page(&self) -> String;
    /// The table invariants the shell relies on.
    fn check(&self) -> Result<(), String>;

    /// The enumeration types the variables use, each once.
    fn enumeration_types(&self) -> Vec<&'static EnumerationType> {
        let mut types: Vec<&'static EnumerationType> = Vec::new();
        for v in self.variables() {
            if let Kind::Enumeration(t) = v.kind {
                if !types.iter().any(|k| std::ptr::eq(*k, t)) {
                    types.push(t);
                }
            }
        }
        types
    }
}

/// The description of an FMU whose table has the fields `model_identifier`, `model_name`,
/// `description`, `variables` and `default_experiment`, and a `guid()`.
macro_rules! fmu_description {
    ($table:ty, $page:path, $check:path) => {
        impl FmuDescription for $table {
            fn model_identifier(&self) -> &'static str {
                self.model_identifier
            }
            fn model_name(&self) -> &'static str {
                self.model_name
            }
            fn description(&self) -> &'static str {
                self.description
            }
            fn variables(&self) -> &[Variable] {
                &self.variables
            }
            fn default_experiment(&self) -> DefaultExperiment {
                self.default_experiment
            }
            fn guid(&self) -> &str {
                <$table>::guid(self)
            }
            fn documentation_page(&self) -> String {
                $page(self)
            }
            fn check(&self) -> Result<(), String> {
                $check(self)
            }
        }
    };
}

fmu_description!(Descriptor, documentation, estimators::check);
fmu_description!(PlantDescriptor, plant_documentation, plants::check);

/// One FMU of the binary.
#[derive(Debug)]
pub enum Fmu {
    /// An estimator.
    Estimator(Descriptor),
    /// A plant.
    Plant(PlantDescriptor),
}

impl Fmu {
    /// Its description.
    pub fn description(&self) -> &dyn FmuDescription {
        match self {
            Fmu::Estimator(d) => d,
            Fmu::Plant(d) => d,
        }
    }
}

/// Every FMU of the binary, built afresh (each instance owns its description: the
/// library keeps no state between calls): the estimators, then the plants.
pub fn all() -> Vec<Fmu> {
    let estimators = estimators::all().into_iter().map(Fmu::Estimator);
    estimators.chain(plants::all().into_iter().map(Fmu::Plant)).collect()
}

/// The FMU with this GUID.
pub fn by_guid(guid: &str) -> Option<Fmu> {
    all().into_iter().find(|f| f.description().guid() == guid)
}
