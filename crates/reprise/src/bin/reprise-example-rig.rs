//! `reprise-example-rig`: the reference external rig evaluator. It speaks the protocol
//! of `reprise_rig::external` (Arrow IPC streams on stdin/stdout) and evaluates the
//! linear rig `reprise_rig::linear::LinearRig` over whatever controls it is sent.
//! The failure flags exist to test how reprise handles a misbehaving evaluator.

use std::io::Write;
use std::sync::Arc;

use arrow::array::{Array, FixedSizeListArray, Float64Array, RecordBatch};
use arrow::datatypes::{DataType, Field, Schema};
use arrow::ipc::reader::StreamReader;
use arrow::ipc::writer::StreamWriter;
use clap::Parser;
use reprise_rig::linear::LinearRig;

/// Reference external rig evaluator (a linear rig) for the Arrow IPC protocol.
#[derive(Parser)]
#[command(name = "reprise-example-rig", version, about)]
struct Args {
    /// Number of vertices of the evaluated mesh.
    #[arg(long, default_value_t = 50)]
    vertices: usize,
    /// Exit with status 3 after answering this many batches (to test early exits).
    #[arg(long)]
    fail_after: Option<usize>,
    /// Stop answering (sleep) after this many batches (to test time-outs).
    #[arg(long)]
    hang_after: Option<usize>,
    /// Answer one pose short after the first batch (to test wrong-size replies).
    #[arg(long)]
    wrong_count: bool,
    /// Answer NaN for the first vertex of every pose after this many batches (to test
    /// non-finite replies).
    #[arg(long)]
    nan_after: Option<usize>,
}

fn main() {
    let args = Args::parse();
    if let Err(e) = serve(&args) {
        eprintln!("reprise-example-rig: error: {e}");
        std::process::exit(1);
    }
}

fn serve(args: &Args) -> Result<(), Box<dyn std::error::Error>> {
    let reader = StreamReader::try_new(std::io::stdin().lock(), None)?;
    let names: Vec<String> = reader.schema().fields().iter().map(|f| f.name().clone()).collect();
    let rig = LinearRig::new(names.clone(), args.vertices);
    let mut writer: Option<StreamWriter<std::io::StdoutLock<'_>>> = None;
    for (answered, batch) in reader.enumerate() {
        let batch = batch?;
        if args.fail_after == Some(answered) {
            eprintln!("reprise-example-rig: failing on purpose after {answered} batches");
            std::process::exit(3);
        }
        if args.hang_after == Some(answered) {
            std::thread::sleep(std::time::Duration::from_secs(3600));
        }
        let columns: Vec<&Float64Array> = (0..names.len())
            .map(|c| batch.column(c).as_any().downcast_ref::<Float64Array>().ok_or("controls must be Float64"))
            .collect::<Result<_, _>>()?;
        let width = 3 * args.vertices;
        let rows = batch.num_rows() - usize::from(args.wrong_count && answered > 0 && batch.num_rows() > 0);
        let mut values = Vec::with_capacity(rows * width);
        let mut out = vec![0.0; width];
        for r in 0..rows {
            let pose: Vec<f64> = columns.iter().map(|c| c.value(r)).collect();
            rig.eval_into(&pose, &mut out);
            if args.nan_after.is_some_and(|n| answered >= n) {
                out[0] = f64::NAN;
            }
            values.extend_from_slice(&out);
        }
        let item = Arc::new(Field::new("item", DataType::Float64, false));
        let list = FixedSizeListArray::try_new(item.clone(), width as i32, Arc::new(Float64Array::from(values)), None)?;
        let schema = Arc::new(Schema::new(vec![Field::new(
            reprise_rig::external::POSITIONS,
            DataType::FixedSizeList(item, width as i32),
            false,
        )]));
        let reply = RecordBatch::try_new(schema.clone(), vec![Arc::new(list)])?;
        if writer.is_none() {
            writer = Some(StreamWriter::try_new(std::io::stdout().lock(), &schema)?);
        }
        let w = writer.as_mut().expect("created above");
        w.write(&reply)?;
        w.get_mut().flush()?;
    }
    if let Some(mut w) = writer {
        w.finish()?;
    }
    Ok(())
}
